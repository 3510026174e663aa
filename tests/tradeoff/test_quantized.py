"""Quantized copies of the corpus' terrains classify like the unquantized ground (the study
docs/method.md quotes, benchmarks/results/quantized.md in full): a few of its cells, held."""

import pytest

from tankcd_cli.tradeoff.quantized import SUB_STEP_FAMILIES, measure, tables
from tankcd_cli.tradeoff.corpus import FAMILIES

SMOOTH = tuple(f for f in FAMILIES if f not in SUB_STEP_FAMILIES)


@pytest.fixture(scope="module")
def cells():
    # the cells the tests read, no more: 20 cm steps only at 2 m posts
    found = measure(spacings=(0.5,), quanta=(0.02, 0.05)) + measure(spacings=(2.0,), quanta=(0.02, 0.05, 0.2))
    return {(c.spacing, c.step): c for c in found}


@pytest.mark.parametrize("spacing,step", [(0.5, 0.02), (0.5, 0.05), (2.0, 0.02), (2.0, 0.05)])
def test_steps_up_to_5_cm_leave_95_percent_of_the_posts_in_their_class(cells, spacing, step):
    c = cells[(spacing, step)]
    assert c.smooth_agreement >= 0.95, (spacing, step, c.by_family)
    assert c.smooth_agreement >= c.smooth_agreement_unfiltered


def test_the_filter_takes_the_terraces_out_where_they_show(cells):
    # at 0.5 m posts 5 cm steps draw contour lines over a quarter of the ground unfiltered
    c = cells[(0.5, 0.05)]
    assert c.smooth_agreement_unfiltered < 0.8 and c.smooth_agreement > 0.97
    assert c.passes == 22 and cells[(2.0, 0.02)].passes == 0  # too fine to show at 2 m posts: left as it is
    assert c.agreement > c.agreement_unfiltered + 0.05  # every family, rough and steps too


def test_coarse_steps_lose_what_lies_between_the_levels(cells):
    # 20 cm steps at 2 m posts (a tenth of the spacing): twice the uneven class's 10 cm chord error;
    # better than unfiltered, short of 95 % (docs/method.md says why)
    c = cells[(2.0, 0.2)]
    assert c.smooth_agreement_unfiltered + 0.1 < c.smooth_agreement < 0.95


def test_the_tables(cells):
    text = tables(list(cells.values()))
    assert "| 0.02 m | **" in text and "By family" in text and all(f in text for f in SMOOTH)
