"""The README's commands cannot rot: every ``bim2rdt`` command in its ```bash blocks names a real command with
options it has, and the fast, side-effect-free ones run (in a temporary folder) and exit 0."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import typer.main

from bim2rdt.cli import app

ROOT = Path(__file__).resolve().parent.parent
RUN_IN_FULL = ("site", "plan", "config", "token")
"""Subcommands the test runs as written: seconds each, writing only into the temporary folder."""


def bash_commands(markdown: str) -> list[str]:
    """The shell commands of every ```bash block: continuation lines joined, comments and a trailing ``&`` cut,
    ``a && b`` split."""
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", markdown, re.DOTALL):
        for line in block.replace("\\\n", " ").splitlines():
            code = " ".join(line.split(" #")[0].split()).rstrip("&").strip()
            commands += [part.strip() for part in code.split("&&") if part.strip()]
    return commands


def bim2rdt_words(command: str) -> list[str] | None:
    """The words after ``bim2rdt`` (environment assignments before it allowed), or None for another program."""
    words = shlex.split(command)
    while words and re.match(r"^[A-Z_][A-Z0-9_]*=", words[0]):
        words = words[1:]
    return words[1:] if words and words[0] == "bim2rdt" else None


def resolve(words: list[str]) -> tuple[object | None, list[str]]:
    """The click command the words name and the options they pass it, or None and the word no command has."""
    command = typer.main.get_command(app)
    rest = list(words)
    while hasattr(command, "commands") and rest and rest[0] in command.commands:  # a group: go down
        command = command.commands[rest.pop(0)]
    if hasattr(command, "commands"):
        return None, [rest[0] if rest else "(no subcommand)"]
    return command, [word.split("=")[0] for word in rest if word.startswith("--")]


def readme_commands() -> list[list[str]]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    return [words for words in map(bim2rdt_words, bash_commands(text)) if words is not None]


def test_the_readme_has_bash_blocks_with_bim2rdt_commands():
    assert len(readme_commands()) >= 10


def test_every_readme_command_and_option_exists():
    wrong = []
    for words in readme_commands():
        command, options = resolve(words)
        if command is None:
            wrong.append(f"bim2rdt {' '.join(words)}: no command {options[0]!r}")
            continue
        known = {opt for param in command.params for opt in (*param.opts, *param.secondary_opts)}
        wrong += [f"bim2rdt {' '.join(words)}: {option}" for option in options if option not in known]
    assert not wrong, "commands or options that do not exist:\n" + "\n".join(wrong)


def test_the_fast_readme_commands_run(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src"), "BIM2RDT_DATA_DIR": str(tmp_path / "var"),
           "BIM2RDT_CACHE_DIR": str(tmp_path / "cache")}
    ran = []
    for command in bash_commands((ROOT / "README.md").read_text(encoding="utf-8")):
        words = bim2rdt_words(command)
        if not words or words[0] not in RUN_IN_FULL:
            continue
        assignments = dict(word.split("=", 1) for word in shlex.split(command) if re.match(r"^[A-Z_]+=", word))
        done = subprocess.run([sys.executable, "-m", "bim2rdt", *words], cwd=tmp_path, env={**env, **assignments},
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, f"{command}\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
        ran.append(words[0])
    assert set(ran) == set(RUN_IN_FULL), f"the README does not show these any more: {set(RUN_IN_FULL) - set(ran)}"


def test_the_command_parser_reads_continuations_comments_and_chains():
    text = "```bash\nbim2rdt plan a.ifc \\\n    --out x   # a comment\nbim2rdt site s.ifc && X=1 bim2rdt config &\n```"
    assert bash_commands(text) == ["bim2rdt plan a.ifc --out x", "bim2rdt site s.ifc", "X=1 bim2rdt config"]
