"""Every Python and shell example of README.md, CHANGELOG.md and docs/ runs as printed (a page
that lies fails here).

Each page's blocks run in order in a fresh folder holding the example files
(``femupdate demo --write-files ex``), Python blocks in one namespace per page, ``femupdate``
commands in process.  The output printed under a ``$`` command of a ``console`` block must
appear in what the command prints (a ``...`` line stands for any lines), and a command shown
failing (``femupdate: error:``) must fail.  Blocks that cannot run here are marked on the page
(``<!-- not run: REASON -->``) and listed as skipped tests with their reason.
"""

from __future__ import annotations

import re
import runpy
import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from docs_blocks import Block, blocks, commands, femupdate_args, output_matches, pages  # noqa: E402

PAGES = pages()
ALL = [b for p in PAGES for b in blocks(p)]
RUN = {p: [b for b in blocks(p) if b.not_run is None] for p in PAGES}


@pytest.fixture(scope="module")
def example_files(tmp_path_factory):
    from femupdate.cli import main

    d = tmp_path_factory.mktemp("examples")
    with pytest.raises(SystemExit) as info:
        main(["demo", "--write-files", str(d / "ex"), "--json", str(d / "demo.json")])
    assert info.value.code == 0
    (d / "demo.json").unlink()
    return d


def _run_femupdate(args: list[str], capsys) -> tuple[int, str]:
    from femupdate.cli import main

    with pytest.raises(SystemExit) as info:
        main(args)
    out, err = capsys.readouterr()
    code = info.value.code
    return (code if isinstance(code, int) else 1), out + err


def _run_block(block: Block, namespace: dict, capsys) -> list[str]:
    """Run one block; what differs from the page (a block that cannot run at all fails at once)."""
    if block.file:
        Path(block.file).write_text(block.text, encoding="utf-8")
        return []
    if block.lang == "python":
        try:
            exec(compile(block.text, block.where, "exec"), namespace)
        except Exception as exc:  # the message names the block
            pytest.fail(f"{block.where} fails: {type(exc).__name__}: {exc}")
        capsys.readouterr()
        return []
    wrong = []
    for cmd in commands(block):
        args = femupdate_args(cmd.argv)
        if args is None and len(cmd.argv) == 2 and cmd.argv[0] in ("python", "python3") and Path(cmd.argv[1]).is_file():
            runpy.run_path(cmd.argv[1], run_name="__main__")  # a script the page wrote (<!-- file: NAME.py -->)
            capsys.readouterr()
            continue
        if args is None:
            pytest.fail(f"{block.where}: {' '.join(cmd.argv)!r} is not a femupdate command: run it or mark the "
                        "block '<!-- not run: REASON -->'")
        code, printed = _run_femupdate(args, capsys)
        shown_failing = any(line.startswith("femupdate: error:") for line in cmd.expected)
        if shown_failing != (code != 0):
            wrong.append(f"{block.where}: {' '.join(cmd.argv)} exited {code}:\n{printed[-3000:]}")
        elif cmd.expected:
            why = output_matches(cmd.expected, printed)
            if why:
                wrong.append(f"{block.where}: the output of {' '.join(cmd.argv)} differs from the page: {why}\n"
                             f"--- printed ---\n{printed[:6000]}")
    return wrong


@pytest.mark.parametrize("page", [p for p in PAGES if RUN[p]], ids=lambda p: p.name)
def test_page_examples_run_as_printed(page, example_files, tmp_path, monkeypatch, capsys):
    work = tmp_path / "work"
    shutil.copytree(example_files, work)
    monkeypatch.chdir(work)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.setenv("COLUMNS", "100")  # the pages show the tables as a 100-column terminal prints them
    namespace: dict = {"__name__": f"docs_{page.stem}"}
    wrong = []
    for block in RUN[page]:
        wrong += _run_block(block, namespace, capsys)
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")
    assert not wrong, f"{len(wrong)} example(s) of {page.name} differ from what they print:\n\n" + "\n\n".join(wrong)


@pytest.mark.parametrize("block", [b for b in ALL if b.not_run is not None], ids=lambda b: f"{b.page}:{b.line}")
def test_block_not_run(block):
    pytest.skip(f"{block.where} not run: {block.not_run}")


def test_the_pages_have_examples_and_every_not_run_block_says_why():
    assert any(p.name == "README.md" for p in PAGES) and len(ALL) > 20
    for b in ALL:
        assert b.not_run is None or len(b.not_run) > 10, f"{b.where}: give the reason in words"


def _slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading (MyST's myst_heading_anchors makes the same)."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower().replace("`", ""))
    return text.replace(" ", "-")


def test_links_of_the_readme_lead_to_files_and_headings_that_exist():
    """The README is not part of the built site (whose build checks its own links): check its links
    here, each to a file of the repository and, for a page, to one of its headings."""
    from docs_blocks import ROOT

    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    links = re.findall(r"\]\(([^)\s]+)\)", readme)
    assert len(links) > 10
    for link in links:
        assert not re.match(r"[a-z]+://", link), f"README.md links outside the repository: {link}"
        path, _, anchor = link.partition("#")
        target = ROOT / path
        assert target.exists(), f"README.md: {link}: no such file"
        if anchor:
            headings = re.findall(r"^#+ (.+)$", target.read_text(encoding="utf-8"), flags=re.M)
            assert anchor in {_slug(h) for h in headings}, f"README.md: {link}: no such heading"
