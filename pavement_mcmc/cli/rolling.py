"""``pavement-mcmc rolling BASE LAW``: next-day forecasts day after day over a long record."""

from __future__ import annotations

import argparse
import re
import sys
import textwrap
from pathlib import Path

from .common import add_json_flag, emit

HELP = ("does a law forecast the next day better than the base model, day after day? (windows "
        "a day apart over the record, each fitted by MAP and forecast from the forcing alone)")


def add_parser(sub) -> None:
    p = sub.add_parser(
        "rolling",
        help=HELP,
        description=textwrap.fill(HELP + ". For every window start (every --step from --from) both cases are "
        "fitted by MAP to --window hours of the record and predict the --horizon hours after it "
        "from the forcing alone (a per-interval h(t) continues as its clock-hour mean). The law "
        "is named when it forecasts better on more days than a fair coin would give (one-sided "
        "sign test, p <= 0.05) and its summed forecast gain F is positive: one held-out day of "
        "smooth errors is too weak a test on a field record, a month of days is not.", 100),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="examples:\n  pavement-mcmc rolling runs/grass.toml runs/grass_energy.toml\n"
        "  pavement-mcmc rolling runs/desert.toml runs/desert.toml+energy_balance_window "
        "--from 2928 --days 10",
    )
    p.add_argument("base", help="case TOML of the base model (CASE.toml+EXT adds an extension)")
    p.add_argument("law", help="case TOML of the model with the law, on the same record")
    p.add_argument("--window", default="72h", metavar="DUR", help="fitted hours (default 72h)")
    p.add_argument("--horizon", default="24h", metavar="DUR", help="forecast hours (default 24h)")
    p.add_argument("--step", default="24h", metavar="DUR",
                   help="from one window start to the next (default 24h)")
    p.add_argument("--from", dest="start", default="0h", metavar="DUR",
                   help="the first window start after the record's first row (default 0h)")
    p.add_argument("--days", type=int, metavar="N", help="number of windows (default: all that fit)")
    p.add_argument("--one-start", action="store_true",
                   help="fit each window from the case's values alone (the earlier rule, to "
                   "reproduce its figures; default: also from the previous window's fit and "
                   "every extension's starts, keeping the lowest training objective)")
    p.add_argument("--figure", metavar="PNG",
                   help="the figure (default: <base>_rolling_<law>.png beside the base TOML)")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..batch.units import parse_duration
    from ..criticism.rolling import rolling_forecast
    from ..plotting.criticism import plot_rolling

    def progress(i, n, day):
        print(f"window {i}/{n} from {day.time}: forecast RMSE base {day.base_rmse:.3f} °C, law "
              f"{day.law_rmse:.3f} °C", file=sys.stderr, flush=True)

    res = rolling_forecast(args.base, args.law, window_h=parse_duration(args.window),
                           horizon_h=parse_duration(args.horizon),
                           step_h=parse_duration(args.step),
                           start_h=parse_duration(args.start, allow_zero=True),
                           days=args.days, one_start=args.one_start, progress=progress)
    base = Path(args.base.split("+")[0])
    law = re.sub(r"[^\w.+-]", "_", Path(args.law).name.replace(".toml", ""))
    fig_path = (Path(args.figure) if args.figure
                else base.with_name(f"{base.stem}_rolling_{law}.png"))
    plot_rolling(res).savefig(fig_path, dpi=110)
    payload = res.to_dict()
    payload["figure"] = str(fig_path)
    emit(args, payload, res.text() + f"\n\nfigure: {fig_path}")
    return 0
