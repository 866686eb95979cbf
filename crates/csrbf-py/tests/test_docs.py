"""The README's and the guide's Python blocks marked to run (`<!-- run -->` on the
line before the block) run as written, beside the bundled assets: a renamed call
breaks this test, not the reader."""

import re
import runpy
import shutil

import pytest

from conftest import ROOT

MARK = "<!-- run -->"


def marked_blocks():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    for page in pages:
        text = page.read_text(encoding="utf-8")
        for k, m in enumerate(re.finditer(re.escape(MARK) + r"\n```python\n(.*?)```", text, re.S)):
            yield pytest.param(m.group(1), id=f"{page.name}-{k}")


BLOCKS = list(marked_blocks())


def test_there_are_blocks_to_run():
    assert len(BLOCKS) >= 2, BLOCKS


@pytest.mark.parametrize("code", BLOCKS)
def test_a_marked_block_runs(code, tmp_path, monkeypatch):
    shutil.copytree(ROOT / "assets", tmp_path / "assets")
    (tmp_path / "out").mkdir()
    monkeypatch.chdir(tmp_path)
    script = tmp_path / "block.py"
    script.write_text(code, encoding="utf-8")
    runpy.run_path(str(script), run_name="__main__")
