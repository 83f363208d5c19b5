"""`zenav completion bash|zsh`: a shell completion script, generated from the command's own parser.

    source <(zenav completion bash)                        # this shell; add it to ~/.bashrc to keep it
    zenav completion zsh > "${fpath[1]}/_zenav"            # zsh (bash's completion through bashcompinit)

It completes subcommands, their options (after a `-`), and the values of options and
arguments with fixed choices; anything else completes as a file name.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterator

from zenav.cli.main import EXIT_OK, build_parser

SHELLS = ("bash", "zsh")


def add_arguments(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    p = sub.add_parser("completion", help="print a shell completion script: source <(zenav completion bash)", description=__doc__)
    p.add_argument("shell", choices=SHELLS)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    print(script(build_parser(), args.shell))
    return EXIT_OK


def commands(parser: argparse.ArgumentParser, path: str = "") -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """(path, parser) of the command and each subcommand, nested: ("", zenav), ("/goto", ...), ("/camera/snapshot", ...)."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield from commands(child, f"{path}/{name}")


def words(parser: argparse.ArgumentParser) -> tuple[list[str], list[str]]:
    """What may follow a command: (its options, its subcommands and the choices of its positional arguments)."""
    options: list[str] = []
    arguments: list[str] = []
    for action in parser._actions:
        if action.option_strings:
            options += [s for s in action.option_strings if s.startswith("--")] or action.option_strings
        elif action.choices is not None:
            arguments += [str(c) for c in action.choices]
    return options, arguments


def option_values(parser: argparse.ArgumentParser) -> dict[str, list[str]]:
    """Option -> its choices, for the options that have them."""
    return {s: [str(c) for c in a.choices] for a in parser._actions if a.option_strings and a.choices is not None for s in a.option_strings}


def bash_script(parser: argparse.ArgumentParser) -> str:
    """The bash completion function of `parser`'s program."""
    prog = parser.prog
    tree = list(commands(parser))
    paths = "|".join(p for p, _ in tree if p)
    values = [f'        "{p}:{opt}") words="{" ".join(choices)}" ;;' for p, sub in tree for opt, choices in option_values(sub).items()]
    cases = [f'                "{p}") options="{" ".join(words(sub)[0])}" arguments="{" ".join(words(sub)[1])}" ;;' for p, sub in tree]
    return "\n".join(
        [
            f"# {prog} completion for bash: source <({prog} completion bash)",
            f"_{prog}() {{",
            '    local cur=${COMP_WORDS[COMP_CWORD]} prev=${COMP_WORDS[COMP_CWORD-1]} path="" words="" options="" arguments="" i',
            "    for ((i = 1; i < COMP_CWORD; i++)); do",
            '        case "$path/${COMP_WORDS[i]}" in',
            f'            {paths}) path="$path/${{COMP_WORDS[i]}}" ;;',
            "        esac",
            "    done",
            '    case "$path:$prev" in',
            *values,
            "        *)",
            '            case "$path" in',
            *cases,
            "            esac",
            "            if [[ $cur == -* ]]; then words=$options; else words=$arguments; fi ;;",
            "    esac",
            '    COMPREPLY=($(compgen -W "$words" -- "$cur"))',
            "}",
            f"complete -o default -F _{prog} {prog}",
        ]
    )


def script(parser: argparse.ArgumentParser, shell: str) -> str:
    """The completion script of `parser` for `shell` (zsh: bash's, through bashcompinit)."""
    if shell == "zsh":
        return f"#compdef {parser.prog}\nautoload -U +X bashcompinit && bashcompinit\n{bash_script(parser)}"
    return bash_script(parser)
