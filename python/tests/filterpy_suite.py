"""FilterPy's own test files run against launch_estimation: the helpers of
test_filterpy_suite.py.

The files come from FilterPy's source distribution (`cargo xtask test` downloads it once into
`target/` and names it in $FILTERPY_SDIST). Each file is copied with every `from filterpy.kalman
import …` split in two: the names launch_estimation provides are imported from it, the rest
still from FilterPy. Run as a script, it prints the rewritten source of one file:

    python filterpy_suite.py path/to/filterpy-2.0.0.tar.gz test_kf.py
"""

import ast
import os
import sys
import tarfile
import warnings

import launch_estimation

HERE = os.path.dirname(os.path.abspath(__file__))
# The version the artefacts below were established against.
VERSION = "2.0.0"
DEFAULT_SDIST = os.path.join(
    HERE, "..", "..", "target", "filterpy-sdist", f"filterpy-{VERSION}.tar.gz"
)
TESTS_DIR = "filterpy/kalman/tests/"

# The FilterPy names this module provides (the rest keep coming from FilterPy).
CANDIDATES = (
    "KalmanFilter",
    "UnscentedKalmanFilter",
    "ExtendedKalmanFilter",
    "IMMEstimator",
    "FixedLagSmoother",
    "MerweScaledSigmaPoints",
    "JulierSigmaPoints",
    "SimplexSigmaPoints",
)
PROVIDED = tuple(name for name in CANDIDATES if hasattr(launch_estimation, name))

# Tests of FilterPy's suite that fail for a documented reason, with the reason. Everything
# else in the swapped files must pass.
ARTEFACTS = {
    ("test_kf.py", "test_procedure_form"): (
        "asserts ‖x − x_FilterPy‖ < 1e-12 absolutely on x of magnitude ~1e4, a bound of a few "
        "ulps of x: the solve with a factor of S instead of FilterPy's inv(S) differs by such "
        "amounts (1.8e-12 to 1.5e-11 seen; the test's data are random, unseeded)"
    ),
    ("test_mmae.py", "test_MMAE2"): (
        "sets cv.Q[2, 2] = 0 on a discrete white-noise Q whose Q[0, 2] and Q[1, 2] stay "
        "nonzero, an indefinite Q: launch_estimation refuses it (ValueError naming Q), "
        "FilterPy runs with it"
    ),
}


def sdist_path():
    """The FilterPy sdist to take the files from: $FILTERPY_SDIST, else the cached default
    (None if neither exists)."""
    path = os.environ.get("FILTERPY_SDIST") or DEFAULT_SDIST
    return path if os.path.exists(path) else None


def suite_sources(sdist):
    """{file name: source} of the test files of filterpy.kalman in the sdist."""
    out = {}
    with tarfile.open(sdist) as tar:
        for member in tar.getmembers():
            name = member.name.split("/", 1)[-1]  # drop "filterpy-2.0.0/"
            if not name.startswith(TESTS_DIR) or not member.isfile():
                continue
            base = name[len(TESTS_DIR):]
            if "/" in base or not base.endswith(".py"):
                continue
            out[base] = tar.extractfile(member).read().decode("utf-8")
    return out


def swap_imports(source, provided=PROVIDED):
    """`source` with each `from filterpy.kalman import …` (at any depth) split: the provided
    names from launch_estimation, the others from filterpy.kalman. Returns (new source, the
    names swapped)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # FilterPy's docstrings hold invalid escapes
        tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    edits, swapped = [], set()
    for node in ast.walk(tree):
        if not (isinstance(node, ast.ImportFrom) and node.module == "filterpy.kalman"):
            continue
        ours = [a for a in node.names if a.name in provided]
        if not ours:
            continue
        theirs = [a for a in node.names if a.name not in provided]
        swapped.update(a.name for a in ours)

        def clause(aliases):
            return ", ".join(a.name + (f" as {a.asname}" if a.asname else "") for a in aliases)

        indent = lines[node.lineno - 1][: node.col_offset]
        text = f"{indent}from launch_estimation import {clause(ours)}\n"
        if theirs:
            text += f"{indent}from filterpy.kalman import {clause(theirs)}\n"
        edits.append((node.lineno, node.end_lineno, text))
    for start, end, text in sorted(edits, reverse=True):
        lines[start - 1 : end] = [text]
    return "".join(lines), swapped


def swapped_files(sdist):
    """{file name: rewritten source} of the test files that use a provided name."""
    out = {}
    for name, source in sorted(suite_sources(sdist).items()):
        if not name.startswith("test_"):
            continue
        new, swapped = swap_imports(source)
        if swapped:
            out[name] = new
    return out


if __name__ == "__main__":
    sys.stdout.write(swapped_files(sys.argv[1])[sys.argv[2]])
