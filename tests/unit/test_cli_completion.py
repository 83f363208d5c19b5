"""`zenav completion`: the script lists the parser's subcommands, options and choices, and bash runs it."""

import shutil
import subprocess

import pytest

from zenav.cli import completion
from zenav.cli.main import MODULES, build_parser, main


def test_words_of_the_command_tree():
    parser = build_parser()
    tree = dict(completion.commands(parser))
    assert {"", "/goto", "/topics", "/completion"} <= tree.keys() and any(p.startswith("/camera/") for p in tree)
    options, commands = completion.words(parser)
    assert options == ["--help", "--version"] and {"goto", "echo", "teleop", "completion"} <= set(commands)
    assert "--wait" in completion.words(tree["/goto"])[0] and "--wait" not in completion.words(tree["/stop"])[0]
    assert completion.option_values(tree["/goto"]) == {"--zenoh-mode": ["client", "peer"]}
    assert completion.words(tree["/completion"]) == (["--help"], ["bash", "zsh"])


def test_completion_prints_the_script(capsys):
    assert main(["completion", "zsh"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("#compdef zenav\n") and "bashcompinit" in out and "complete -o default -F _zenav zenav" in out


def complete(line):
    """What bash completes for `line` (the last word is the one completed) with the generated script."""
    script = completion.script(build_parser(), "bash")
    words = line.split(" ")
    shell = f'{script}\nCOMP_WORDS=({" ".join(repr(w) for w in words)}); COMP_CWORD={len(words) - 1}; _zenav; echo "${{COMPREPLY[*]}}"'
    done = subprocess.run(["bash", "-c", shell], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


@pytest.mark.skipif(shutil.which("bash") is None, reason="no bash")
def test_bash_completes_subcommands_options_and_choices():
    assert complete("zenav go") == ["goto"]
    assert set(complete("zenav ")) >= {"goto", "topics", "completion"} and complete("zenav --") == ["--help", "--version"]
    assert complete("zenav turn --de") == ["--deg"] and complete("zenav turn --direction ") == ["auto", "cw", "ccw"]
    assert complete("zenav echo --robot r2 --zenoh-mode ") == ["client", "peer"]
    assert complete("zenav camera s") == ["snapshot", "stream"]
    assert complete("zenav completion ") == ["bash", "zsh"]
    assert complete("zenav stop --w") == []  # stop has no --wait
    assert complete("zenav goto ") == []  # numbers: nothing to offer (bash falls back to file names)


def test_every_module_has_its_command_in_the_script():
    script = completion.script(build_parser(), "bash")
    assert all(f"/{name}" in script for name in ("goto", "status", "topics", "echo", "hz", "query", "teleop"))
    assert len(MODULES) == len(set(MODULES))
