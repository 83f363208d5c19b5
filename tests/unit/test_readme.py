"""README.md and docs/ stay true: their links lead somewhere in the repository, and every
zenav command they show is one the zenav command accepts."""

from __future__ import annotations

import importlib.util
import re
import shlex
import sys
from pathlib import Path

import pytest

from zenav import __version__
from zenav.cli.main import build_parser, main
from zenav.common.keys import SERVICES

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

REPO = Path(__file__).resolve().parents[2]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")
RUN = {"./run up": "zenav up --demo", "./run bench": "zenav bench", "./run zenav": "zenav"}  # what ./run runs
ENV = re.compile(r"^([A-Z_]+=\S+\s+)+")
MODULE = re.compile(r"python -m (zenav[\w.<>]*)")


def slug(heading: str) -> str:
    """The anchor GitHub gives a heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(page: Path) -> set[str]:
    return {slug(line.lstrip("#")) for line in page.read_text().splitlines() if line.startswith("#")}


def links(page: Path) -> list[str]:
    return [t for t in LINK.findall(page.read_text()) if not re.match(r"[a-z]+:", t)]


def commands(page: Path) -> list[str]:
    """The zenav command lines of the page's shell blocks, as the zenav command sees them."""
    out, in_block = [], False
    for line in page.read_text().splitlines():
        if line.startswith("```"):
            in_block = line.strip() == "```sh"
            continue
        text = ENV.sub("", line.split("  #")[0].strip())
        if not in_block or not text:
            continue
        for prefix, cmd in RUN.items():
            if text.startswith(prefix):
                text = cmd + text[len(prefix) :]
        if text.startswith("zenav "):
            out.append(text)
    return out


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.relative_to(REPO).as_posix())
def test_links_lead_to_files_and_headings_in_the_repository(page):
    broken = []
    for target in links(page):
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.is_relative_to(REPO) or not dest.exists():
            broken.append(f"{target}: no such file in the repository")
        elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
            broken.append(f"{target}: no heading #{anchor} in {dest.relative_to(REPO)}")
    assert not broken, f"{page.relative_to(REPO)}: " + "; ".join(broken)


def test_readme_starts_with_how_to_run_and_drive_it():
    text = (REPO / "README.md").read_text()
    quick = text[: text.index("## Services")]
    for line in ("./run up ", "./run test ", "./run zenav goto 0.5 0.5 --wait"):
        assert f"\n{line}" in quick, f"README's quick start lacks {line!r}"
    assert "](docs/contract.md)" in text


def test_every_command_shown_is_accepted(capsys):
    shown = [(page, cmd) for page in PAGES for cmd in commands(page)]
    assert len(shown) >= 20  # the extraction found the command blocks
    parser = build_parser()
    refused = []
    for page, cmd in shown:
        try:
            parser.parse_args(shlex.split(cmd)[1:])
        except SystemExit:
            refused.append(f"{page.relative_to(REPO)}: {cmd}")
    capsys.readouterr()
    assert not refused, "commands the zenav command refuses:\n" + "\n".join(refused)


def test_every_module_run_with_python_m_exists():
    named = {mod for page in PAGES for mod in MODULE.findall(page.read_text())}
    modules = {mod.replace("<svc>", s) for mod in named for s in (SERVICES if "<svc>" in mod else [""])}
    assert len(modules) >= 3
    missing = sorted(mod for mod in modules if importlib.util.find_spec(mod) is None)
    assert not missing, f"README.md or docs/ run modules that do not exist: {missing}"


def test_readme_names_every_extra_of_the_package():
    readme = (REPO / "README.md").read_text()
    install = readme[readme.index("## Install") : readme.index("## Services")]
    listed = set(re.findall(r"^\| `([\w-]+)` \|", install, re.MULTILINE))
    extras = set(tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["optional-dependencies"])
    assert extras <= listed, f"README's Install lacks the extras {sorted(extras - listed)}"


def test_version(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out == f"zenav {__version__}\n"


def test_the_figures_readme_quotes_are_the_committed_reports():
    """README's "How well it works" measures nothing itself: each figure it gives (the targets' measured
    column, and its paragraphs) is one docs/bench/report.md prints."""
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("## How well it works") : readme.index("Each part alone")]
    quoted = []
    for line in section.splitlines():
        cells = line.split("|")
        if line.startswith("|") and len(cells) == 6 and not set(cells[3]) <= set("-: "):
            quoted.append(cells[3])  # a target's measured figures (its goal is no measurement)
        elif not line.startswith("|"):
            quoted.append(line)
    decimals = re.compile(r"(?<![\w.])\d+\.\d+(?![\w.])")
    printed = set(decimals.findall((REPO / "docs" / "bench" / "report.md").read_text()))
    figures = [x for text in quoted for x in decimals.findall(text)]
    assert len(figures) > 20
    assert [x for x in figures if x not in printed] == []


def test_the_user_docs_stay_under_30000_words():
    """README and docs/ (not the contract, which the code generates, nor the bench report) are read by users:
    what to install, run, drive, configure and how far to trust each figure, not the history of a measurement."""
    counted = [page for page in PAGES if page.name != "contract.md"]
    words = {page.relative_to(REPO).as_posix(): len(page.read_text().split()) for page in counted}
    assert len(counted) >= 10 and sum(words.values()) < 30_000, (
        f"{sum(words.values())} words: {sorted(words.items(), key=lambda kv: -kv[1])}"
    )
