"""Every Python snippet of the README and the guide (docs/*.md) runs against the built module.

A fenced block whose info string is `python` is executed as it stands, in a fresh namespace
and a scratch working directory, so a snippet that stops matching the module fails here.
"""

import os
import re

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def documents():
    docs = [os.path.join(ROOT, "README.md")]
    guide = os.path.join(ROOT, "docs")
    docs += sorted(os.path.join(guide, f) for f in os.listdir(guide) if f.endswith(".md"))
    return docs


def snippets():
    found = []
    for doc in documents():
        with open(doc, encoding="utf-8") as f:
            text = f.read()
        for m in re.finditer(r"^```python[^\n]*\n(.*?)^```\s*$", text, re.M | re.S):
            line = text[: m.start()].count("\n") + 1
            found.append(pytest.param(m.group(1), id=f"{os.path.basename(doc)}:{line}"))
    return found


SNIPPETS = snippets()


def test_the_documents_have_python_snippets():
    # The README's and the getting-started chapter's at least: losing them silently would
    # make the test below vacuous.
    assert len(SNIPPETS) >= 2


@pytest.mark.parametrize("code", SNIPPETS)
def test_snippet_runs(code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<snippet>", "exec"), {"__name__": "__snippet__"})
