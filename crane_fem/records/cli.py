"""``crane-fem records match``: the command line of spectrum-compatible records."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from crane_fem.errors import CraneFemError, ScenarioError

__all__ = ["DEFAULT_N", "DEFAULT_PERIODS", "add_parser", "run"]

DEFAULT_N = 7  # the codes' mean over ≥ 7 records (ASCE 4, EN 1998-1 §4.3.3.4.3)
#: A crane's modes lie at 5–100 Hz, periods 0.01–0.2 s; the codes' 0.2 T1–2 T1 around its
#: first mode (0.2 s) reaches 0.4 s; 1 s keeps a softer support structure's first modes in.
DEFAULT_PERIODS = (0.01, 1.0)

_DESCRIPTION = """\
Match seed records to a target spectrum (reqpy-m, wavelet-based spectral matching), so that
each record's spectrum stays within -10 %/+30 % of the target over a band of periods and the
records' mean is not below it (ASCE 4, RG 1.208).

TARGET is either
  ec8:type=T,ag=A,soil=S   EN 1998-1 elastic horizontal spectrum: T = 1 or 2, A = a_g in m/s2
                           or in g with a 'g' suffix (0.3g), S = ground type A..E; its
                           damping correction eta from --damping
  ec8:type=T,ag=A,direction=vertical
                           EN 1998-1 §3.2.2.3 elastic vertical spectrum (a_vg/a_g, T_B, T_C,
                           T_D of Table 3.4; no ground type)
  FILE.csv                 rows 'period (s), PSA (m/s2)', periods increasing, header allowed;
                           a run's spectra.csv (several columns) with --column NAME

Seeds: by default the bundled El Centro 1940 horizontal pair in four directions
(el_centro_1940_180, _225, _270, _315: the recorded components and the pair in axes turned by
45 deg). --seed-records replaces them with files (.AT2 in g, or CSV 't, a' in m/s2) or bundled
names. Record k takes seed k mod m, as recorded, then reversed in time: at most 2 m records.

Writes DIR/record_<k>.csv (t s, a m/s2: loading.ground_motion.record = "record_1.csv"),
DIR/match.json (target, band, per record: seed, scale, min/max/mean ratio to the target;
the verdict), DIR/match_spectra.csv and DIR/match.png. Exit 1 if the band check fails.
"""

_EXAMPLE = """\
example:
  crane-fem records match ec8:type=1,ag=0.3g,soil=B -o out/records
  crane-fem records match floor.csv --damping 0.02 --periods 0.01 0.5 \\
      --seed-records my_1.AT2 my_2.csv -o out/floor_records
"""


def add_parser(sub: argparse._SubParsersAction) -> None:
    """Add ``records`` (and its ``match``) to the ``crane-fem`` subcommands."""
    records = sub.add_parser(
        "records", help="spectrum-compatible records: seeds matched to a target spectrum"
    )
    rsub = records.add_subparsers(dest="records_command", required=True, metavar="{match}")
    match = rsub.add_parser(
        "match",
        help="match seed records to a target spectrum (EC8 or a table)",
        description=_DESCRIPTION,
        epilog=_EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    match.add_argument("target", metavar="TARGET", help="ec8:type=1,ag=0.3g,soil=B or FILE.csv")
    match.add_argument(
        "--damping",
        type=float,
        default=0.05,
        metavar="ZETA",
        help="damping ratio of the target spectrum, and of the matched spectra (default 0.05)",
    )
    match.add_argument(
        "--n", type=int, default=DEFAULT_N, metavar="N", help=f"records (default {DEFAULT_N})"
    )
    match.add_argument(
        "--seed-records",
        nargs="+",
        default=None,
        metavar="SEED",
        help="seed record files or bundled names (default: the El Centro pair, 4 directions)",
    )
    match.add_argument(
        "--periods",
        nargs=2,
        type=float,
        default=DEFAULT_PERIODS,
        metavar=("T_MIN", "T_MAX"),
        help="the band's periods in s (default 0.01 1: a crane's 5-100 Hz and a margin; "
        "the codes ask for 0.2 T1 to 2 T1 around the structure's first period T1)",
    )
    match.add_argument(
        "--column", default=None, metavar="NAME", help="the PSA column of a multi-column CSV"
    )
    match.add_argument(
        "-o", "--output", type=Path, required=True, metavar="DIR", help="output directory"
    )


def _say(line: str) -> None:
    print(f"crane-fem: {line}", flush=True)


def run(args: argparse.Namespace) -> int:
    """Run ``crane-fem records match`` (one process); 0 when the band check passes.

    Raises:
        ScenarioError: bad input (a target, a seed, the band, N, the damping), one line.
        CraneFemError: the records do not meet the band (the files are written).
    """
    # The matching's modules (scipy.signal, reqpy) here, not at the parser's import: every
    # command builds the parser.
    from crane_fem.records.matching import Band, longest_period, match_records, matching_range
    from crane_fem.records.report import record_file, write_outputs
    from crane_fem.records.seeds import DEFAULT_SEEDS, check_seed_length, load_seed, plan_variants
    from crane_fem.records.targets import parse_target

    if args.records_command != "match":  # pragma: no cover  (argparse allows match only)
        raise ScenarioError(f"unknown records command {args.records_command!r}")
    zeta = float(args.damping)
    if not (math.isfinite(zeta) and 0.0 <= zeta < 1.0):
        raise ScenarioError(f"--damping is a ratio in [0, 1) (0.05 for 5 %), got {args.damping}")
    target = parse_target(args.target, zeta, args.column)
    band = Band(float(args.periods[0]), float(args.periods[1]))
    matching_range(target, band, 0.0)  # the band inside the target, before any reading
    seeds = [load_seed(s) for s in (args.seed_records or DEFAULT_SEEDS)]
    longest = longest_period(target, band)
    for seed in seeds:
        check_seed_length(seed, longest)
    variants = plan_variants(seeds, int(args.n))
    out: Path = args.output
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ScenarioError(f"{out}: cannot create the output directory ({exc})") from None
    _say(
        f"matching {len(variants)} records to {target.label} over "
        f"{band.t_min:g}-{band.t_max:g} s (reqpy-m)"
    )

    result = match_records(variants, target, band, _say)
    write_outputs(out, result)
    mean = result.mean_ratio
    _say(
        f"mean/target {mean.min():.3f}-{mean.max():.3f}; wrote {out}/record_1..{len(variants)}"
        ".csv, match.json, match_spectra.csv, match.png"
    )
    if not result.passed:
        bad = [record_file(k) for k, r in enumerate(result.records) if not result.within(r)]
        what = [f"{', '.join(bad)} outside the band"] if bad else []
        if not result.mean_not_below:
            what.append(f"the mean {mean.min():.3f} of the target")
        raise CraneFemError(f"the band check failed: {'; '.join(what)} (see {out}/match.json)")
    _say("band check passed: each record within -10 %/+30 %, the mean not below the target")
    return 0
