"""The README and docs/: short front door, links that resolve, commands that exist.

Every relative link in ``README.md`` and ``docs/**/*.md`` names an existing
file (and, for a Markdown file, an existing heading); every ``python X.py``
names an existing script; every ``terrain-odom`` command line names an
existing subcommand with options it has; ``docs/cli.md`` documents every
option of every subcommand; the Python examples run as written.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import re
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

from terrain_odom.cli.main import build_parser, main

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
PAGES = [README, *sorted(DOCS.rglob("*.md"))]
RESULTS = sorted((DOCS / "results").glob("*.md"))
MAX_README_LINES = 400

FENCE = re.compile(r"^```[^\n]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
CODE_SPAN = re.compile(r"`([^`\n]+)`")
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*#*\s*$", re.MULTILINE)
OPTION = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
SCRIPT = re.compile(r"(?<![\w-])python3?\s+([\w./-]+\.py)\b")
# a file of the repository quoted in the text, optionally with a test: tests/x.py::test_y
REPO_PATH = re.compile(
    r"(?<![\w./-])((?:bench|config|examples|models|sample_images|src|tests)/[\w./-]*\w)(?:::(\w+))?"
)
COMMAND = re.compile(r"terrain-odom(?:\s+[^\s|]+)*")
# one subcommand's section of docs/cli.md: "## run", "## report accuracy" ...
CLI_SECTION = re.compile(r"^## (.+)$", re.MULTILINE)


def _rel(path: Path) -> str:
    return str(path.relative_to(REPO))


def _prose(text: str) -> str:
    """Return ``text`` without fenced code blocks and code spans (where links are not links)."""
    return CODE_SPAN.sub("", FENCE.sub("", text))


def _code(text: str) -> list[str]:
    """Return every code line: fenced lines (backslash continuations joined) and code spans."""
    pieces = CODE_SPAN.findall(FENCE.sub("", text))
    for block in FENCE.findall(text):
        pieces += block.replace("\\\n", " ").splitlines()
    return pieces


def _slug(heading: str) -> str:
    """Return GitHub's anchor of a Markdown heading."""
    text = re.sub(r"[^\w\- ]", "", heading.replace("`", "").strip().lower())
    return text.replace(" ", "-")


@cache
def _anchors(path: Path) -> frozenset[str]:
    seen: dict[str, int] = {}
    anchors = set()
    for heading in HEADING.findall(FENCE.sub("", path.read_text(encoding="utf-8"))):
        slug = _slug(heading)
        anchors.add(slug if slug not in seen else f"{slug}-{seen[slug]}")
        seen[slug] = seen.get(slug, 0) + 1
    return frozenset(anchors)


@cache
def _help(*words: str) -> str:
    """Return the help ``terrain-odom WORDS --help`` prints."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as exit_:
        main([*words, "--help"])
    assert exit_.value.code == 0, words
    return out.getvalue()


def _choices(*words: str) -> list[str]:
    """Return the subcommands listed in the usage line of ``terrain-odom WORDS --help``."""
    usage = _help(*words).split("\n\n")[0]
    return re.search(r"\{([\w,-]+)\}", usage).group(1).split(",")


def _subcommands() -> list[tuple[str, ...]]:
    """Return every runnable subcommand as its words: ("run",), ("report", "accuracy") ..."""
    words: list[tuple[str, ...]] = []
    for name in _choices():
        if name == "report":
            words += [("report", sub) for sub in _choices("report")]
        else:
            words.append((name,))
    return words


def _options(*words: str) -> set[str]:
    """Return the options in the usage line of ``terrain-odom WORDS --help``."""
    return set(OPTION.findall(_help(*words).split("\n\n")[0])) - {"--help"}


def _commands(text: str) -> list[str]:
    """Return every ``terrain-odom ...`` command in the code of ``text``, comments dropped."""
    return [m for line in _code(text) for m in COMMAND.findall(line.split(" #")[0])]


def test_readme_is_a_short_front_door():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= MAX_README_LINES
    headings = {h for h in HEADING.findall(README.read_text(encoding="utf-8"))}
    assert {"Install", "Tests", "Quick start"} <= headings  # .ci/run refers to the first two


def test_readme_shows_the_commands_ci_runs():
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    code = _code(README.read_text(encoding="utf-8"))
    for command in ('pip install -e ".[dev]"', "python -m pytest -n auto"):
        assert command in ci and command in code, command


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_relative_links_resolve(page):
    for target in LINK.findall(_prose(page.read_text(encoding="utf-8"))):
        if re.match(r"[a-z]+:", target):
            continue  # http(s), mailto
        path, _, anchor = target.partition("#")
        resolved = (page.parent / path).resolve() if path else page
        assert resolved.exists(), f"{_rel(page)}: {target}"
        if anchor and resolved.suffix == ".md":
            assert anchor in _anchors(resolved), f"{_rel(page)}: {target}"


def test_docs_are_linked_from_their_index():
    index = DOCS / "README.md"
    linked = {(index.parent / t).resolve() for t in LINK.findall(index.read_text("utf-8"))}
    for page in DOCS.rglob("*.md"):
        assert page == index or page in linked, _rel(page)


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_every_quoted_script_exists(page):
    for script in SCRIPT.findall(page.read_text(encoding="utf-8")):
        assert (REPO / script).is_file(), f"{_rel(page)}: python {script}"


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_every_quoted_repository_path_exists(page):
    for path, test in REPO_PATH.findall(page.read_text(encoding="utf-8")):
        if path.endswith(".npz"):
            continue  # models/default.npz: package data, found wherever it is installed
        assert (REPO / path).exists(), f"{_rel(page)}: {path}"
        if test:
            assert f"def {test}(" in (REPO / path).read_text(encoding="utf-8"), f"{path}::{test}"


def test_the_results_quote_their_commands():
    for page in RESULTS:
        text = page.read_text(encoding="utf-8")
        assert SCRIPT.search(text) or _commands(text), _rel(page)


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_every_quoted_command_names_a_subcommand_and_its_options(page):
    subcommands = _subcommands()
    for command in _commands(page.read_text(encoding="utf-8")):
        words = command.split()[1:]
        if not words or words[0].isupper():
            continue  # "terrain-odom SUBCOMMAND --help": a placeholder
        if words[0].startswith("--"):
            assert words[0] in _options(), f"{_rel(page)}: {command}"
            continue
        sub = tuple(words[:2]) if words[0] == "report" else tuple(words[:1])
        assert sub in subcommands, f"{_rel(page)}: {command}"
        unknown = set(OPTION.findall(command)) - _options(*sub)
        assert not unknown, f"{_rel(page)}: {command}: {sorted(unknown)}"


def _parsers(
    parser: argparse.ArgumentParser, words: tuple[str, ...] = ()
) -> Iterator[tuple[tuple[str, ...], argparse.ArgumentParser]]:
    """Yield every runnable subcommand's words and parser: ("run",), ("report", "accuracy") ..."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        yield words, parser
    for sub in subs:
        for name, child in sub.choices.items():
            yield from _parsers(child, (*words, name))


def test_cli_reference_documents_every_option_of_every_parser():
    text = (DOCS / "cli.md").read_text(encoding="utf-8")
    parts = CLI_SECTION.split(text)
    sections = dict(zip(parts[1::2], parts[2::2], strict=True))
    old_column = [  # the last column of the grammar table: the deprecated spellings
        line.split("|")[-2] for line in sections["One grammar"].splitlines() if line.startswith("|")
    ]
    walked = dict(_parsers(build_parser()))
    assert set(walked) == set(_subcommands())
    for words, parser in walked.items():
        name = " ".join(words)
        assert name in sections, f"docs/cli.md has no '## {name}'"
        shown = {
            option
            for action in parser._actions
            if action.help != argparse.SUPPRESS
            for option in action.option_strings
            if option not in ("-h", "--help")
        }
        missing = shown - set(OPTION.findall(sections[name]))
        assert not missing, f"docs/cli.md '## {name}' lacks {sorted(missing)}"
        # deprecated spellings: parsed, never shown, named in the grammar table
        aliases = set(parser._option_string_actions) - shown - {"-h", "--help"}
        for alias in aliases:
            assert any(f"`{alias}" in cell for cell in old_column), f"{name} {alias}: undocumented"


@pytest.mark.parametrize("page", [README, DOCS / "models.md"], ids=_rel)
def test_python_examples_run_as_written(page, monkeypatch, capsys):
    blocks = re.findall(r"^```python\n(.*?)^```", page.read_text("utf-8"), re.M | re.S)
    assert blocks
    monkeypatch.chdir(REPO)
    for block in blocks:
        exec(compile(block, f"{_rel(page)} example", "exec"), {"__name__": "example"})
    capsys.readouterr()


def test_readme_api_example_prints_its_state(monkeypatch, capsys):
    block = re.search(r"^```python\n(.*?)^```", README.read_text("utf-8"), re.M | re.S)
    monkeypatch.chdir(REPO)
    exec(compile(block.group(1), "README example", "exec"), {"__name__": "example"})
    assert capsys.readouterr().out.strip() == "x=0.49 m  yaw=0.35 rad  terrain=grass"
