"""``pavement-mcmc export runs/X out.nc``: ArviZ InferenceData (netCDF) of a run."""

from __future__ import annotations

import argparse
import sys

HELP = "export a run as an ArviZ InferenceData netCDF file (needs the optional arviz extra)"


def add_parser(sub) -> None:
    p = sub.add_parser(
        "export", help=HELP,
        description=HELP + ": posterior, sample_stats, pointwise log_likelihood, "
        "posterior_predictive and observed_data. pip install 'pavement_mcmc[arviz]'.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("run", help="run directory (holding chain.h5)")
    p.add_argument("out", help="output netCDF file, e.g. out.nc")
    p.add_argument("--thin", type=int, default=None,
                   help="keep every THIN-th kept step (default: at most 250 draws per walker)")
    p.add_argument("--burn-in", type=int, default=None, help="steps to discard")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..runs import load_view
    from ..runs.export import export_netcdf, import_arviz

    try:
        import_arviz()
    except ImportError as err:
        print(f"pavement-mcmc export: error: {err}", file=sys.stderr)
        return 2
    view = load_view(args.run, burn_in=args.burn_in)
    out = export_netcdf(view, args.out, thin=args.thin)
    print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB): groups posterior, sample_stats, "
          "log_likelihood, posterior_predictive, observed_data")
    return 0
