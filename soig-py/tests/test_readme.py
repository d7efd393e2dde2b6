"""The README's Python example runs as written (its output folder moved to a temporary one)."""

import os
import re

from conftest import REPO


def test_readme_example(tmp_path, capsys):
    readme = (REPO / "README.md").read_text()
    m = re.search(r"<!-- tested by soig-py/tests/test_readme.py -->\s*```python\n(.*?)```",
                  readme, re.S)
    assert m, "README.md: no Python example after the test's marker"
    code = m.group(1)
    assert '"runs/py-demo"' in code
    code = code.replace('"runs/py-demo"', repr(str(tmp_path / "py-demo")))
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        exec(compile(code, "README.md", "exec"), {})
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "(1024, 1024) float32" in out
    assert (tmp_path / "py-demo" / "manifest.json").is_file()
