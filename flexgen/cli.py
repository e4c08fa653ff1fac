"""The command line: builds the parser from flexgen/commands/, turns errors into one-line
messages and exit codes.

Exit codes: 0 success, 1 the work ran but failed (stale files, no equilibrium), 2 bad input,
130 interrupted (Ctrl-C), 141 the reader of stdout went away (``| head``), as other Unix tools.
With `solve --json` or `select --json`, a scene that cannot be solved at all (bad input, or a bug)
still prints the contract's object on stdout: ``"converged": false`` and the ``"reason"``.
Bad input, a missing optional extra, an unusable or failed output file: the commands raise and
main() reports, as one line on stderr with control characters escaped; an unexpected exception is
reported the same way ("internal error", exit 1) rather than as a traceback (FLEXGEN_TRACEBACK=1
re-raises). Work that ran and failed (no equilibrium, stale generated files, a sweep's worker or
scheduler lost) is the command's own outcome: it prints one line the same way and returns 1.
Nothing below this module exits.
"""

from __future__ import annotations

import argparse
import difflib
import errno
import importlib
import os
import re
import sys

from flexgen.codegen.spec import SpecError
from flexgen.commands.common import MissingExtra, UsageError
from flexgen.outfiles import OutputError, UnusableTarget, WriteFailed

# subcommand modules under flexgen/commands/, in the order `flexgen --help` lists them
COMMANDS = ("generate", "solve", "plot", "select", "sweep", "bench", "stability")

# the subcommands whose --json prints a Result: on bad input too (the contract)
JSON_COMMANDS = ("solve", "select")

# exceptions whose message is a complete one-line answer to the user (exit 2)
USER_ERRORS: tuple[type[Exception], ...] = (UsageError, SpecError, OutputError)


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, no usage dump (main adds a hint: _hint)
        raise _ParseError(message)


class _ParseError(UsageError):
    """The parser's own message: main adds the hint for a misspelled word (_hint)."""


def _command_of(argv: list) -> str | None:
    """The subcommand among arguments that did not parse: the first that is one (options such
    as --version may come before it)."""
    return next((str(a) for a in argv if str(a) in COMMANDS), None)


def _options(
    parser: argparse.ArgumentParser, command: str | None, top: bool = True
) -> tuple[set[str], set[str]]:
    """(every option string, those that take a value) of ``command``'s subparser, and with
    ``top`` of the top level too (argparse reports an unknown word on the top-level parser,
    which alone does not know which subcommand's options were meant)."""
    actions = list(parser._actions) if top else []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and command in action._name_parser_map:
            actions += action._name_parser_map[command]._actions
    options = {option for action in actions for option in action.option_strings}
    valued = {o for action in actions if action.nargs != 0 for o in action.option_strings}
    return options, valued


def _resolved(word: str, options: set[str]) -> str:
    """The option ``word`` names: itself, or the one option it abbreviates (argparse takes
    unique prefixes), else ``word``."""
    name = word.split("=", 1)[0]
    prefixed = [o for o in options if o.startswith(name)]
    return name if name in options else prefixed[0] if len(prefixed) == 1 else name


def _hint(parser: argparse.ArgumentParser, argv: list, message: str) -> str:
    """ "; did you mean 'solve'?" for a misspelled subcommand or option of the command given
    (as a scene key's message has: review, `flexgen slove` and `--modle` got none), or where
    to look."""
    choice = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
    if choice is not None:
        known = re.findall(r"'([^']*)'", choice[2])
        close = difflib.get_close_matches(choice[1], known, n=1)
        return f"; did you mean {close[0]!r}?" if close else ""
    if message.startswith("unrecognized arguments:"):
        command = _command_of(argv)
        own = _options(parser, command, top=command is None)[0]
        top = {o for action in parser._actions for o in action.option_strings}
        for word in message.split(":", 1)[1].split():
            name = word.split("=", 1)[0]
            if not word.startswith("-"):
                continue
            if command is not None and name in top - own:  # flexgen solve x.toml --version
                return f"; {name} goes before the command (flexgen {name})"
            candidates = sorted(own - {name})
            close = difflib.get_close_matches(name, candidates, n=2, cutoff=0.75)
            if close:
                return f"; did you mean {' or '.join(map(repr, close))}?"
        return f" (see flexgen {command or 'COMMAND'} --help)"
    if "the following arguments are required: command" in message:
        return " (one of: " + ", ".join(COMMANDS) + "; see flexgen --help)"
    return ""


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("flexgen")
    except PackageNotFoundError:  # pragma: no cover - run from a tree not installed
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="flexgen",
        description=(
            "Smooth curvature model of planar flexures: generate NumPy and C99 kernels from the "
            "SymPy derivation, and solve scenes of flexures, links, loads and tendons."
        ),
    )
    parser.add_argument("--version", action="version", version=f"flexgen {_version()}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"flexgen.commands.{name}")
        except ImportError as exc:  # the core missing or stale: the command says so when run
            if not _core_unavailable(exc):
                raise
            p = sub.add_parser(name, help="(needs flexgen's compiled core, which is not usable)")
            p.add_argument("arguments", nargs=argparse.REMAINDER)
            p.set_defaults(run=_needs_the_core(exc), core_missing=True)
            continue
        module.register(sub)
    return parser


def _user_errors() -> tuple[type[Exception], ...]:
    errors = list(USER_ERRORS)
    try:  # the runtime's input errors, when present
        from flexgen.scene import SceneError

        errors.append(SceneError)
    except ImportError:
        pass
    return tuple(errors)


def main(argv=None) -> int:
    # a name the output's encoding cannot write (a Japanese scene name on a cp1252 stdout, the
    # default of a redirected stdout on Windows) is written as an escape, not an internal error
    # (review); stderr does so by default
    reconfigure = getattr(sys.stdout, "reconfigure", None)
    if reconfigure is not None:
        try:
            reconfigure(errors="backslashreplace")
        except (ValueError, OSError):  # a stream that cannot change now: left as it is
            pass
    try:
        return _main(argv)
    except (MemoryError, RecursionError) as exc:  # pragma: no cover - the limits prevent them
        _error(f"out of resources ({type(exc).__name__})")
        return 1


def entry() -> None:
    """The ``flexgen`` program (console script and ``python -m flexgen``): ``main``, then exit
    with its status, a Ctrl-C after ``main`` returned ignored. By then the answer is out and the
    files are written; Python's shutdown (joining threads, flushing) turned a Ctrl-C there into
    a death by SIGINT (130, no message) or a traceback with exit 0 (review: a script dropped a
    finished study). ``main`` itself leaves the handler alone (tests call it in process)."""
    import signal

    status = main()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.exit(status)


def _core_unavailable(exc: BaseException) -> bool:
    """The compiled core is missing or older than its sources (flexgen.core.CoreUnavailable,
    named so that this module does not import the core)."""
    return type(exc).__name__ == "CoreUnavailable"


def _needs_the_core(error: ImportError):
    """A subcommand's run when its module cannot load without the core: the error, raised."""

    def run(args) -> int:
        raise error

    return run


def _main(argv) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    args = None
    parser = None
    try:
        # inside the try: building the parser imports every subcommand's module, and a Ctrl-C
        # then is an interruption like any other (the package's own import, before main, is
        # not covered: docs/sweep.md)
        parser = build_parser()
        args = parser.parse_args(argv)
        status = args.run(args)
        sys.stdout.flush()  # a write error of the answer surfaces here, not at exit
        return status
    except UnusableTarget as exc:  # an output path that is a folder, a FIFO: bad input
        _error(f"error: cannot write {exc.path}: {exc.why}")
        return 2
    except WriteFailed as exc:  # a full disk, a size limit: not bad input
        _error(f"cannot write {exc.path}: {exc.why}")
        return 1
    except _user_errors() as exc:
        text = str(exc)
        if isinstance(exc, _ParseError) and parser is not None:
            text += _hint(parser, argv, text)
        _error(f"error: {text}")
        _json_failure(argv, args, text, parser)
        return 2
    except MissingExtra as exc:  # the install, not the input: exit 1, as flexgen plot's
        _error(f"error: {exc}")
        return 1
    except KeyboardInterrupt:
        _error("interrupted")
        return 130

    except BrokenPipeError:
        # the reader (e.g. `| head`) went away: stop quietly, as other Unix tools do
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except Exception as exc:
        if _core_unavailable(exc):  # the install or build, not the input: exit 1
            _error(f"error: {exc}")
            _json_failure(
                argv, None if getattr(args, "core_missing", False) else args, str(exc), parser
            )
            return 1
        if isinstance(exc, OSError) and _stdout_refused(exc):
            # a full disk or device behind stdout: the answer is lost, said in one line
            _error(f"cannot write to standard output: {exc.strerror or exc}")
            return 1
        # a bug, not an answer: one line all the same (FLEXGEN_TRACEBACK=1 shows the traceback)
        if os.environ.get("FLEXGEN_TRACEBACK"):
            raise
        message = f"internal error: {type(exc).__name__}: {exc} (please report it)"
        _error(message)
        _json_failure(argv, args, message, parser)
        return 1


# what a write to a full or failing device raises (no file name: not a file flexgen opened,
# whose errors are its own messages)
_WRITE_ERRNOS = {errno.ENOSPC, errno.EIO, errno.EFBIG, errno.EDQUOT, errno.EBADF}


def _stdout_refused(exc: OSError) -> bool:
    """Whether ``exc`` is stdout refusing the answer (a full disk, /dev/full); stdout is then
    pointed at /dev/null, so that nothing more is tried, the interpreter's last flush
    included."""
    if exc.filename is not None or exc.errno not in _WRITE_ERRNOS:
        return False
    os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return True


def _json_failure(argv: list, args, message: str, parser: argparse.ArgumentParser | None) -> None:
    """With `solve --json` (or `select --json`), the answer to a scene that could not be solved
    still goes to stdout (the contract: ``"converged": false`` and the reason), after the one
    line on stderr. Before the arguments parse, ``--json`` is looked for among them."""
    if args is not None:
        wanted = args.command in JSON_COMMANDS and getattr(args, "json", False)
    else:  # --json as given, or abbreviated as argparse takes it (review: --js)
        command = _command_of(argv)
        options = _options(parser, command)[0] if parser is not None else set()
        wanted = command in JSON_COMMANDS and any(
            str(a).startswith("--") and _resolved(str(a), options) == "--json" for a in argv
        )
    if not wanted:
        return
    from flexgen.commands.common import printable
    from flexgen.result import Result
    from flexgen.scene import scene_name_of

    if args is not None:
        scene = str(getattr(args, "scene", "") or "")
    else:  # the scene file as given: the first argument after the command that is no option
        scene = _scene_argument(argv, parser)
    scene = scene_name_of(scene) if scene else scene  # its name, as a solved answer's
    reason = printable(_shortened(" ".join(str(message).split())))
    try:
        print(Result.unsolvable(printable(scene), reason).to_json(indent=2), flush=True)
    except BrokenPipeError:  # the reader went away (`| head`): quiet, as main's own handler
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except OSError as exc:  # stdout refuses it: the one line on stderr stands
        if not _stdout_refused(exc):
            raise


def _scene_argument(argv: list, parser: argparse.ArgumentParser | None) -> str:
    """The scene file among arguments that did not parse: the first after the command that is
    neither an option (or an abbreviation argparse takes for one) nor the value of one (review:
    `solve --tol 2 --json x.toml` named its answer "2")."""
    command = _command_of(argv)
    # no parser (building it failed: the error being reported): every option a flag then
    options, valued = _options(parser, command) if parser is not None else (set(), set())
    rest = argv[argv.index(command) + 1 :] if command is not None else argv
    value_next, found = False, []
    for arg in map(str, rest):
        if value_next:
            value_next = False
        elif arg.startswith("-"):
            value_next = "=" not in arg and _resolved(arg, options) in valued
        else:
            found.append(arg)
    # an unknown option's value looks like a scene: a TOML file's name is preferred
    return next((a for a in found if a.endswith(".toml")), found[0] if found else "")


# a quoted name or value in a message: shortened past 80 characters (docs/scene.md, Errors). A
# quote opens where a word may start and closes where one may end (a quote inside a value, as in
# it's, is part of it): the prose between two short quoted values is not one (review: "'exact'
# solves the whole scene; give it to eve...xact" lost the advice)
_END = r"[\s)\]},.:;?!]"  # what may follow a closing quote ("did you mean 'x'?")
_OPENS, _CLOSES = r"(?<![^\s(\[{=:,])", rf"(?={_END}|$)"
_QUOTED = re.compile(
    "|".join(rf"{_OPENS}{q}(?:[^{q}\n]|{q}(?!{_END}|$)){{81,}}{q}{_CLOSES}" for q in ("'", '"'))
)


def _shortened(text: str) -> str:
    """``text`` with every quoted part longer than 80 characters cut to its first 40 and last
    37, '...' between: a path keeps its file name (found by review: a 3000-character flexure
    name made a 6066-character message)."""
    return _QUOTED.sub(lambda m: m.group(0)[:40] + "..." + m.group(0)[-37:], text)


def _error(message: str) -> None:
    """``flexgen: <message>`` on stderr as one line of printable text, long quoted names and
    values shortened."""
    from flexgen.commands.common import printable

    text = printable(_shortened(" ".join(str(message).split())))
    print(f"flexgen: {text}", file=sys.stderr)


if __name__ == "__main__":
    sys.exit(main())
