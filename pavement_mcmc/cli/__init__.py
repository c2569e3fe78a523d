"""The ``pavement-mcmc`` command line. Each sub-command lives in its own module of this package
and provides ``add_parser(subparsers)`` and ``run(args) -> int``. Only the CLI prints."""

from __future__ import annotations

import argparse
import errno
import importlib
import platform
import signal
import sys
import traceback
import warnings
from pathlib import Path

from .. import __version__
from ..data.errors import UserError
from ..storage.files import DISK_FULL

#: sub-command name -> module in this package (in the order ``--help`` lists them)
COMMANDS = {
    "simulate": "simulate",
    "fit": "fit",
    "resume": "fit",
    "diagnostics": "diagnostics",
    "report": "report",
    "sensitivity": "sensitivity",
    "export": "export",
    "urban": "urban",
    "diagnose": "diagnose",
    "compare": "compare",
    "rolling": "rolling",
    "batch": "batch",
}

_DESCRIPTION = """\
Estimate the thermal conductivity kappa, the volumetric heat capacity C and the surface heat
transfer coefficient h(t) of a pavement from buried temperature sensors (Bayesian MCMC over a
1D heat-conduction model), then criticise the model: where it fails and which effect is missing.

Typical loop:
  pavement-mcmc fit runs/caseA.toml --out runs/caseA      sample the posterior
  pavement-mcmc diagnostics runs/caseA                     can the chain be trusted?
  pavement-mcmc report runs/caseA                          one HTML file with every figure
  pavement-mcmc diagnose runs/caseA                        which physical effect is missing?
  pavement-mcmc fit runs/caseA.toml --add two_layer --out runs/caseA_2l
  pavement-mcmc compare runs/caseA runs/caseA_2l          watch the error fall
  pavement-mcmc rolling runs/grass.toml runs/grass_energy.toml
                                     does the law forecast the next day better, day after day?
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pavement-mcmc",
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"pavement_mcmc {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    seen = set()
    for module in COMMANDS.values():
        if module in seen:
            continue
        seen.add(module)
        importlib.import_module(f".{module}", __name__).add_parser(sub)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """The package's warnings (ignored columns, time gaps, ...) as one plain line for users;
    other libraries' warnings keep Python's format (file and line)."""
    if str(filename).startswith(_PACKAGE_DIR):
        print(f"warning: {message}", file=file or sys.stderr)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), end="",
              file=file or sys.stderr)


_PACKAGE_DIR = str(Path(__file__).resolve().parents[1])


#: a full disk, a quota, a file-size limit, a failing device: one line, not a traceback
_DISK_ERRORS = DISK_FULL | {errno.EIO}


def _split_sets(argv: list[str]) -> list[str]:
    """``--set a=1 b=2 case.toml`` -> ``--set=a=1 --set=b=2 case.toml``: argparse's ``nargs='+'``
    would take the case file as one more assignment; an assignment always has a ``=``."""
    out: list[str] = []
    it = iter(argv)
    for tok in it:
        if tok != "--set":
            out.append(tok)
            continue
        items = []
        for nxt in it:
            if "=" in nxt and not nxt.startswith("-"):
                items.append(nxt)
                continue
            out += [f"--set={x}" for x in items] if items else ["--set"]
            out.append(nxt)
            break
        else:
            out += [f"--set={x}" for x in items] if items else ["--set"]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(_split_sets(sys.argv[1:] if argv is None else list(argv)))
    if hasattr(signal, "SIGXFSZ"):  # over `ulimit -f`: a write error (EFBIG), not a core dump
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    from ..runs.threads import single_blas_thread

    try:
        with single_blas_thread(), warnings.catch_warnings():
            warnings.showwarning = _show_warning  # one BLAS thread for compare / diagnose too
            return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except UserError as err:  # DataError, ConfigError, StoreMismatch, RunError, ...
        print(f"pavement-mcmc {args.command}: error: {err}", file=sys.stderr)
        return 2
    except Exception as err:  # anything else is a bug (but a full disk): show it
        if isinstance(err, OSError) and err.errno in _DISK_ERRORS:
            print(f"pavement-mcmc {args.command}: error: writing {err.filename or 'a file'} "
                  f"failed: {err.strerror}; free space and run the command again",
                  file=sys.stderr)
            return 2
        traceback.print_exc()
        print(f"\npavement-mcmc {args.command}: this is a bug in pavement_mcmc, not in your input. "
              f"Please report it with the command line above and this traceback "
              f"(pavement_mcmc {__version__}, {platform.platform()}, Python "
              f"{platform.python_version()}).", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
