"""The command-line reference, generated from phasemap's argparse parser.

``.. phasemap-cli::`` renders :func:`phasemap.cli.build_parser`: the program's
description, then one section per subcommand with its usage, description,
arguments (with defaults and choices, as ``--help`` expands them) and examples.
The page cannot drift from the parser: it *is* the parser, read at build time.
"""

from __future__ import annotations

import argparse
import textwrap

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles


def parser_and_subcommands() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser],
                                      dict[str, str]]:
    """The top-level parser, its subcommand parsers by name and their one-line help."""
    from phasemap.cli import build_parser

    built = build_parser()
    parser = built[0] if isinstance(built, tuple) else built
    subs: dict[str, argparse.ArgumentParser] = {}
    helps: dict[str, str] = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            subs.update(action.choices)
            helps.update({a.dest: a.help or "" for a in action._choices_actions})
    return parser, subs, helps


def _unwrap(text: str | None) -> str:
    """argparse descriptions are filled to the terminal: join each paragraph's lines."""
    if not text:
        return ""
    paragraphs = [" ".join(p.split()) for p in text.strip().split("\n\n")]
    return "\n\n".join(p for p in paragraphs if p)


def _help(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """An argument's help with ``%(default)s`` and friends expanded, as ``--help`` shows it."""
    if not action.help or action.help == argparse.SUPPRESS:
        return ""
    formatter = parser._get_formatter()
    return " ".join(formatter._expand_help(action).split())


def _invocation(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    formatter = parser._get_formatter()
    return formatter._format_action_invocation(action)


def _literal(lines: list[str], text: str) -> None:
    lines += ["::", ""] + ["   " + line for line in text.rstrip().splitlines()] + [""]


def _rst_escape(text: str) -> str:
    return text.replace("\\", "\\\\").replace("*", "\\*").replace("`", "\\`").replace("|", "\\|")


def arguments_rst(parser: argparse.ArgumentParser) -> list[str]:
    """An option list of ``parser``'s arguments (help and version flags left out)."""
    lines: list[str] = []
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        if action.help == argparse.SUPPRESS:
            continue
        lines.append(f"``{_invocation(parser, action)}``")
        text = _help(parser, action)
        if action.choices is not None and not isinstance(action.choices, dict):
            choices = ", ".join(f"``{c}``" for c in action.choices)
            if "{" not in _invocation(parser, action):
                text += f" (one of {choices})"
        lines += ["    " + (_rst_escape(text) or "(no help)"), ""]
    return lines


def cli_rst() -> list[str]:
    """The whole command-line reference as reStructuredText lines."""
    parser, subs, helps = parser_and_subcommands()
    prog = parser.prog
    lines = [_rst_escape(_unwrap(parser.description)), ""]
    _literal(lines, parser.format_usage().replace("usage: ", "", 1))
    lines += arguments_rst(parser)
    lines += ["Subcommands:", ""]
    lines += [f"* :ref:`{prog} {name} <cli-{name}>`: {_rst_escape(helps.get(name, ''))}"
              for name in subs]
    lines.append("")
    for name, sub in subs.items():
        title = f"``{prog} {name}``"
        lines += [f".. _cli-{name}:", "", title, "-" * len(title), ""]
        if helps.get(name):
            lines += [_rst_escape(helps[name][:1].upper() + helps[name][1:]) + ".", ""]
        _literal(lines, sub.format_usage().replace("usage: ", "", 1))
        description = _unwrap(sub.description)
        if description and description != helps.get(name):
            lines += [_rst_escape(description), ""]
        args = arguments_rst(sub)
        if args:
            lines += ["**Arguments**", ""] + args
        if sub.epilog:
            lines += ["**Examples**", ""]
            _literal(lines, textwrap.dedent(sub.epilog.split("\n", 1)[1]))
    return lines


class PhasemapCli(SphinxDirective):
    """``.. phasemap-cli::``: the reference of every subcommand, from the parser."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        node = nodes.section()
        node.document = self.state.document
        content = StringList(cli_rst(), source="phasemap.cli.build_parser")
        nested_parse_with_titles(self.state, content, node)
        return node.children


def setup(app):
    app.add_directive("phasemap-cli", PhasemapCli)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
