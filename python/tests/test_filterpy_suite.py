"""FilterPy's own test files (from its source distribution), with the names launch_estimation
provides imported from it, pass — except the documented artefacts in filterpy_suite.py.

Each file runs in a child pytest (a crash fails that file, not the run), with matplotlib's
non-interactive backend (the files draw plots) and FilterPy's own tests/ folder as its working
directory, so its local helpers import."""

import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

import filterpy_suite as suite

SDIST = suite.sdist_path()
if SDIST is None:
    if os.environ.get("FILTERPY_SDIST"):
        raise RuntimeError(f"FILTERPY_SDIST names a missing file: {os.environ['FILTERPY_SDIST']}")
    pytest.skip(
        "FilterPy's sdist is not cached (cargo xtask test fetches it into target/)",
        allow_module_level=True,
    )
FILES = suite.swapped_files(SDIST)


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """FilterPy's kalman tests folder, every file copied as is, the swapped ones rewritten."""
    d = tmp_path_factory.mktemp("filterpy_kalman_tests")
    for name, source in suite.suite_sources(SDIST).items():
        (d / name).write_text(FILES.get(name, source), encoding="utf-8")
    return d


def run_file(workdir, name):
    """{test name: "passed" | "failed: …" | "skipped"} of one file run by a child pytest."""
    report = workdir / (name + ".xml")
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-W", "ignore",
         f"--junitxml={report}", name],
        cwd=workdir,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert report.exists(), f"{name}: the child pytest died ({proc.returncode}): {proc.stderr[-2000:]}"
    out = {}
    for case in ET.parse(report).getroot().iter("testcase"):
        test = case.get("name")
        bad = case.find("failure")
        if bad is None:
            bad = case.find("error")
        if bad is not None:
            out[test] = "failed: " + (bad.get("message") or "").splitlines()[0][:300]
        elif case.find("skipped") is not None:
            out[test] = "skipped"
        else:
            out[test] = "passed"
    return out


def test_the_suite_is_there():
    # KalmanFilter's own file and the ones built on it (IMM, MMAE, RTS, fusion, FLS, …).
    assert {"test_kf.py", "test_imm.py", "test_rts.py", "test_sensor_fusion.py"} <= set(FILES)
    # The unscented filter's file and the cubature filter's, which compares against it.
    assert {"test_ukf.py", "test_ckf.py"} <= set(FILES)


def test_artefacts_name_real_tests():
    sources = suite.suite_sources(SDIST)
    for (name, test) in suite.ARTEFACTS:
        assert f"def {test}(" in sources[name], (name, test)


@pytest.mark.parametrize("name", sorted(FILES))
def test_filterpy_file(workdir, name):
    outcomes = run_file(workdir, name)
    assert outcomes, f"{name}: no test ran"
    unexpected = {
        test: what
        for test, what in outcomes.items()
        if what != "passed" and (name, test) not in suite.ARTEFACTS
    }
    assert not unexpected, f"{name}: {unexpected}"
