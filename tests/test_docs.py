"""The front door and the manual: the README's size, the docs site's strict build, and
every Python example on the pages run as written.

The examples are read out of the markdown (every ```` ```python ```` block of README.md and
of the pages under docs/), not copied here: a page's blocks run in order in one namespace,
as a reader would paste them. A snippet that is not meant to run is fenced as ``text``,
``sh`` or ``yaml``. The examples keep to a few hundred frames of training at most.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"

_PYTHON_BLOCK = re.compile(r"^```python\n(.*?)^```", re.DOTALL | re.MULTILINE)


def python_blocks(text: str) -> list[str]:
    """The ```python fenced blocks of a markdown text, in order."""
    return _PYTHON_BLOCK.findall(text)


def pages_with_examples() -> list[Path]:
    pages = [README, *sorted(DOCS.rglob("*.md"))]
    return [page for page in pages if python_blocks(page.read_text())]


def test_python_blocks_are_read_as_fenced() -> None:
    text = "intro\n```python\nx = 1\n```\n```sh\nls\n```\n```python\ny = x + 1\n```\n"
    assert python_blocks(text) == ["x = 1\n", "y = x + 1\n"]


def test_the_readme_is_a_front_door() -> None:
    text = README.read_text()
    assert len(text) <= 10_000, f"README.md has {len(text)} characters; results go in docs/"
    for must in ("make demo", "make test", "make docs", "## Layout", "docs/demo.png"):
        assert must in text
    assert len(python_blocks(text)) == 1  # the bolt-your-own-env example


def test_the_tutorials_have_examples_that_run() -> None:
    tutorials = sorted((DOCS / "tutorials").glob("*.md"))
    assert len(tutorials) >= 6
    with_code = [page.stem for page in tutorials if python_blocks(page.read_text())]
    assert {"bolt-your-env", "writing-specs", "your-own-detector"} <= set(with_code)


def test_no_page_points_at_this_machine() -> None:
    for page in [README, *DOCS.rglob("*.md"), ROOT / "mkdocs.yml"]:
        text = page.read_text()
        assert "/work/" not in text and "../shared" not in text, page


@pytest.mark.parametrize(
    "page", pages_with_examples(), ids=lambda page: str(page.relative_to(ROOT))
)
def test_the_examples_on_a_page_run(
    page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Run where a reader would, but write nothing into the checkout (runs/, caches).
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(tmp_path / "cache"))
    namespace: dict[str, object] = {"__name__": f"docs_example_{page.stem}"}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a page's warnings are its own text's business
        for number, block in enumerate(python_blocks(page.read_text()), start=1):
            code = compile(block, f"{page.relative_to(ROOT)} (python block {number})", "exec")
            exec(code, namespace)


def test_the_site_builds_without_a_warning(tmp_path: Path) -> None:
    mkdocs = shutil.which("mkdocs", path=str(Path(sys.executable).parent))
    if mkdocs is None:
        pytest.fail('mkdocs is missing: install the docs extra (pip install -e ".[docs]")')
    site = tmp_path / "site"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    build = subprocess.run(
        [mkdocs, "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert build.returncode == 0, build.stdout + build.stderr
    # The generated pages are there: the command's reference from its parser, the API
    # from the docstrings (noisybolt.__all__ and a page per subpackage).
    cli = (site / "reference" / "cli" / "index.html").read_text()
    assert "noisybolt-train" in cli and "--trust-code" in cli
    api = (site / "reference" / "api" / "index.html").read_text()
    import noisybolt

    for name in noisybolt.__all__:
        if not name.startswith("__"):
            assert f"noisybolt.{name}" in api, name
    assert (site / "reference" / "api" / "logic" / "index.html").exists()
    errors = (site / "reference" / "errors" / "index.html").read_text()
    assert "UntrustedCodeError" in errors and "UnsatisfiableSpecError" in errors
