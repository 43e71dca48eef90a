"""The documentation: every relative link resolves (tools/check_links.py), and the README stays a user's page."""
from __future__ import annotations

import subprocess
from pathlib import Path

from tools import check_links

ROOT = Path(__file__).resolve().parents[1]
README_MAX_LINES = 250


def test_every_link_resolves_and_nothing_points_outside():
    problems = check_links.check(ROOT)
    assert not problems, "\n".join(problems)


def test_readme_is_short():
    n = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines, more than {README_MAX_LINES}: move detail into docs/"


def test_github_slugs():
    assert check_links.slug("Set up and run (fresh machine, Python 3.11)") == "set-up-and-run-fresh-machine-python-311"
    assert check_links.slug("`inbetween new` from drawings") == "inbetween-new-from-drawings"
    assert check_links.slug("Version 2: any number of keys, frames, easing (`inbetween-shot/2`)") == \
        "version-2-any-number-of-keys-frames-easing-inbetween-shot2"
    assert check_links.anchors("# A\n## A\n```\n# not a heading\n```\n## A\n") == {"a", "a-1", "a-2"}


def _repo(tmp_path: Path, files: dict[str, str]) -> Path:
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    subprocess.run(["git", "-C", str(tmp_path), "add", "-A"], check=True)
    return tmp_path


def test_broken_links_are_reported_one_line_each(tmp_path):
    root = _repo(tmp_path, {
        "README.md": "# Top\n[ok](docs/a.md#part-one) [self](#top) ![pic](docs/p.png) [web](https://x.org/y)\n"
                     "[gone](docs/missing.md) [bad anchor](docs/a.md#nope)\n"
                     "`[in code](nowhere.md)`\n```\n[fenced](nowhere.md)\n```\n",
        "docs/a.md": "# A\n## Part one\n[up](../README.md) [out](../../elsewhere.md) [dir](../docs/)\n",
        "docs/p.png": "png",
        "notes.txt": "data in " + check_links.OUTSIDE + "/realdev\n",
    })
    problems = check_links.check(root)
    assert len(problems) == 4, problems
    assert any(p.startswith("README.md:3: docs/missing.md") for p in problems)
    assert any(p.startswith("README.md:3: docs/a.md#nope") for p in problems)
    assert any(p.startswith("docs/a.md:3: ../../elsewhere.md") for p in problems)
    assert any(p.startswith("notes.txt:1:") for p in problems)
    assert check_links.main(["--root", str(root)]) == 1


def test_an_untracked_target_is_broken(tmp_path):
    root = _repo(tmp_path, {"README.md": "[new](docs/new.md)\n"})
    (root / "docs").mkdir()
    (root / "docs" / "new.md").write_text("# New\n")  # on disk but not added: a clone would not have it
    assert [p.split(":")[0] for p in check_links.check(root)] == ["README.md"]


def test_cli_md_names_every_command_and_option():
    """docs/cli.md has a section per subcommand of assets/cli.py, naming each of its arguments (an option added to
    the parser without its documentation fails here)."""
    import argparse

    from assets.cli import _parser

    text = (ROOT / "docs" / "cli.md").read_text(encoding="utf-8")
    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    missing = []
    for name, parser in sub.choices.items():
        head = f"\n## `inbetween {name}`\n"
        assert head in text, f"docs/cli.md has no section {head.strip()}"
        section = text.split(head, 1)[1].split("\n## ", 1)[0]
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            names = action.option_strings or [action.dest.upper().rstrip("S")]
            missing += [f"{name} {n}" for n in names if f"`{n}" not in section]
    assert not missing, f"docs/cli.md does not name: {', '.join(missing)}"
