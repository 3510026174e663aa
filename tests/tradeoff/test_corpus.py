"""The rule ``auto`` ships is the one the generated corpus supports, and the corpus is deterministic."""

import numpy as np

from tankcd_cli.matching.match import AUTO_RULE
from tankcd_cli.tolerances import ATTITUDE_TOLERANCE_DEG
from tankcd_cli.tradeoff.corpus import build_surface, corpus_poses, corpus_table, corpus_terrains, measure_corpus
from tankcd_cli.vehicle import vehicle_preset

T72 = vehicle_preset("t72")


def test_the_shipped_rule_is_the_corpus_winners():
    # the whole corpus (the winners are its counts, not its times): the escalation's five timed
    # rounds left out
    result = measure_corpus(T72, pairs=0)
    assert result["winners"] == AUTO_RULE, corpus_table(result)
    # every class has poses from several families: the table is not decided by a handful
    for row in result["rows"]:
        assert row["poses"] > 1000, row
    table = corpus_table(result)
    assert "**(rule)**" in table and "Rule: flat -> " in table
    # escalated auto holds the certificate's bound over the whole corpus (grids and TINs, every
    # family): the attitude error's 95th percentile within the attitude tolerance, each class's
    # height error's within the height tolerance (29 mm)
    assert result["escalated_attitude_p95_deg"] <= ATTITUDE_TOLERANCE_DEG, result["escalated_attitude_p95_deg"]
    for row in result["auto"]:
        if row["matcher"] == "auto, escalated":
            assert row["attitude_p95_deg"] <= ATTITUDE_TOLERANCE_DEG, row
            assert row["height_p95_mm"] <= result["tolerance_m"] * 1000, row


def test_the_corpus_is_deterministic():
    terrains = corpus_terrains()
    assert len({t.name for t in terrains}) == len(terrains)
    for i in (3, 17):  # a grid and a TIN
        a, b = build_surface(terrains[i], T72, seed=i), build_surface(terrains[i], T72, seed=i)
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.class_raster, b.class_raster)
    for x, y in zip(corpus_poses(T72, 5), corpus_poses(T72, 5)):
        np.testing.assert_array_equal(x, y)
