"""tankcd tradeoff: what accuracy costs in time, as a reproducible report."""

from __future__ import annotations

import sys

import click

from tankcd_cli.cli.options import no_dash_directory, no_stdin, verbosity_options
from tankcd_cli.tradeoff.measure import ratio_text
from tankcd_cli.tradeoff.report import run_tradeoff


@click.command(short_help="Measure what accuracy costs in time: tables, CSV and plots.")
@click.option("--scene", type=click.Path(), default=None, callback=no_stdin,
              help="Measure on this scene's terrain, vehicle and obstacles (default: the sample battlefield).")
@click.option("--trajectory", type=click.Path(), default=None,
              help="Trajectory CSV for the headline (default: the sample patrol, or a drive over the scene's terrain).")
@click.option("--out", "out_dir", type=click.Path(file_okay=False), default="tankcd-tradeoff", show_default=True,
              callback=no_dash_directory,
              help="Directory for tradeoff.md, tradeoff.csv and tradeoff.png.")
@click.option("--quick", is_flag=True, help="Small inputs, 3 repeats and 7 pairs behind each ratio, without the "
                                            "matcher corpus, for CI: well under a minute on 2 cores (the full run "
                                            "takes several minutes).")
@verbosity_options
@click.pass_obj
def tradeoff(report, scene, trajectory, out_dir, quick):
    """Run every variant of every stage on the same inputs, each judged against an independent
    truth: curvature methods (analytic surfaces), matchers and a three-point tripod (the
    rigid-hull reference), tree layouts and python-fcl/coal where installed (brute force), the
    two-plane internal test (the exact cylinder test), auto against always-reference on a
    whole replay (the headline), and the trajectory's motion logged at 1 to 50 Hz, replayed
    along the motion and at the rows alone (what the rows miss, against the continuous check).
    Every ratio comes with its pairs' range. Writes OUT/tradeoff.md, tradeoff.csv and tradeoff.png."""
    res = run_tradeoff(out_dir, scene, trajectory, quick, progress=report.progress("tradeoff"),
                       command="tankcd " + " ".join(sys.argv[1:]))
    h = res.headline
    for r in res.rates:
        report.detail(f"tradeoff: {r.hz:g} Hz: {sum(r.contacts.values())} contacts, the rows alone miss "
                      f"{sum(r.missed.values())}; continuous {r.ratio:.2f}x the rows-only time "
                      f"(pairs {r.ratio_lo:.2f}-{r.ratio_hi:.2f}x)")
    report.info(f"tradeoff: auto is {ratio_text(h['speedup'], *h['speedup_spread'], 'faster', 'slower', 'reference')} "
                f"than reference for a median attitude error of "
                f"{h['attitude_error_median_deg']:.2f} deg; wrote tradeoff.md, tradeoff.csv, tradeoff.png in "
                f"{out_dir} ({report.elapsed():.1f} s)")
