"""The Python examples of the README and docs/guide.md run as written, so they cannot rot.

Each ```python block runs in a fresh directory in which `plans`, `scenarios` and `docs` link to the
repository's. A block preceded by `<!-- not run: why -->` is skipped with that reason.
"""

import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]
DOCUMENTS = [REPO / "README.md", REPO / "docs" / "guide.md"]


def python_blocks():
    """(place, code, reason not run or None) of every ```python block of the documents."""
    found = []
    for doc in DOCUMENTS:
        last_text = ""
        block = None  # (language, place, not run, lines) of the open block
        for number, line in enumerate(doc.read_text(encoding="utf-8").splitlines(), start=1):
            fence = line.strip().startswith("```")
            if block is not None:
                if fence:
                    language, place, not_run, code = block
                    if language == "python":
                        found.append((place, "\n".join(code) + "\n", not_run))
                    block = None
                    last_text = line
                else:
                    block[3].append(line)
            elif fence:
                marker = last_text.strip()
                not_run = None
                if marker.startswith("<!-- not run:") and marker.endswith("-->"):
                    not_run = marker[len("<!-- not run:") : -len("-->")].strip()
                place = f"{doc.relative_to(REPO)}:{number}"
                block = (line.strip()[3:].strip(), place, not_run, [])
            elif line.strip():
                last_text = line
        assert block is None, f"{doc}: a code block is not closed"
    return found


BLOCKS = python_blocks()


def test_the_documents_have_python_examples():
    assert len(BLOCKS) >= 2, BLOCKS


@pytest.mark.parametrize("place,code,not_run", BLOCKS, ids=[b[0] for b in BLOCKS])
def test_python_example_runs(place, code, not_run, tmp_path, monkeypatch):
    if not_run:
        pytest.skip(not_run)
    for name in ("plans", "scenarios", "docs"):
        (tmp_path / name).symlink_to(REPO / name)
    monkeypatch.chdir(tmp_path)
    exec(compile(code, place, "exec"), {"__name__": "__docs__"})
