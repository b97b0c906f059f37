"""Every option of every command says in its ``--help`` what it does and what its default is, under one name.

The rule, checked on every parser (the main one and every subcommand's, recursively through subparsers):

* an option that takes a value and is not required has a help text, and its help *as printed* names its default:
  the words "default" (``(default: 600)``, appended by :class:`craft_dsl.cli.HelpFormatter` to the help of an
  option whose default is a value, or written in the help: ``(default 600 = 10 s)``, ``(default: stdout)``), once;
  an option whose default is None or empty (``--out``, ``--param``) says in words what happens without it;
* exempt: ``-h/--help`` and ``--version``; flags (``store_true``, ``store_false``, ``store_const``, ``count``:
  nargs 0), whose default is off, which goes without saying (their help must still exist); required options,
  which have no default; hidden deprecated aliases (:class:`craft_dsl.cli.DeprecatedAlias`);
* one long name per option: no two long names of a parser set the same destination, except a deprecated alias
  (hidden, warns on stderr when used).
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from collections.abc import Iterator

import pytest

from craft_dsl.cli import DeprecatedAlias, build_parser, main


def _parsers(parser: argparse.ArgumentParser, name: str = "craft-dsl") -> Iterator[tuple[str, argparse.ArgumentParser]]:
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub_name, sub in action.choices.items():
                yield from _parsers(sub, f"{name} {sub_name}")


PARSERS = dict(_parsers(build_parser()))


def _exempt(action: argparse.Action) -> bool:
    return (isinstance(action, (argparse._HelpAction, argparse._VersionAction, DeprecatedAlias))
            or action.nargs == 0 or action.required)


def _printed_help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    formatter = parser._get_formatter()
    return formatter._expand_help(action) if action.help else ""  # what --help prints beside the option


def test_the_walk_finds_every_command() -> None:
    for name in ("craft-dsl generate", "craft-dsl read", "craft-dsl engines compare", "craft-dsl scenes stats",
                 "craft-dsl simulate", "craft-dsl perceive noise", "craft-dsl score", "craft-dsl hf"):
        assert name in PARSERS, sorted(PARSERS)


@pytest.mark.parametrize("name", sorted(PARSERS))
def test_every_option_has_help_that_names_its_default(name: str) -> None:
    parser = PARSERS[name]
    problems = []
    for action in parser._actions:
        if not action.option_strings or isinstance(action, (argparse._HelpAction, argparse._VersionAction)):
            continue
        option = "/".join(action.option_strings)
        if isinstance(action, DeprecatedAlias):
            if action.help is not argparse.SUPPRESS:
                problems.append(f"{option}: a deprecated alias is hidden from --help")
            continue
        if not action.help:
            problems.append(f"{option}: no help text")
            continue
        if _exempt(action):
            continue
        printed = _printed_help(parser, action)
        if "default" not in printed.lower():
            problems.append(f"{option}: the help does not name the default ({action.default!r}): {printed!r}")
        elif printed.lower().count("(default") > 1:
            problems.append(f"{option}: the default is named twice: {printed!r}")
    assert not problems, f"{name}:\n" + "\n".join(problems)


@pytest.mark.parametrize("name", sorted(PARSERS))
def test_one_long_name_per_option(name: str) -> None:
    names: dict[str, set[str]] = defaultdict(set)
    for action in PARSERS[name]._actions:
        if isinstance(action, DeprecatedAlias):
            continue
        names[action.dest].update(o for o in action.option_strings if o.startswith("--"))
    assert {dest: sorted(n) for dest, n in names.items() if len(n) > 1} == {}


def test_help_shows_each_default_once(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "(default: 0)" in out and "(default 600 = 10 s)" in out
    assert "(default: False)" not in out  # flags: off unless given
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert "(default 0) (default: 0)" not in out and "(default: None)" not in out


def test_jobs_is_a_hidden_deprecated_alias_of_workers(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["engines", "compare", "--help"])
    assert "--jobs" not in capsys.readouterr().out
    args = build_parser().parse_args(["engines", "compare", "--jobs", "3"])
    assert args.workers == 3
    assert capsys.readouterr().err == "warning: --jobs is deprecated; use --workers\n"
    args = build_parser().parse_args(["engines", "compare", "--workers", "2"])
    assert args.workers == 2 and capsys.readouterr().err == ""
