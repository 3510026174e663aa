"""How the report states a ratio: only what its pairs support."""

from tankcd_cli.tradeoff.timing import Paired, cost_text, paired, ratio_text


def test_a_ratio_whose_pairs_agree_is_stated_with_its_spread():
    assert ratio_text(3.14, 2.8, 3.4, "faster", "slower") == "3.1x faster (pairs 2.8-3.4x)"
    assert ratio_text(0.5, 0.4, 0.6, "faster", "slower") == "2.0x slower (pairs 1.7-2.5x)"
    assert cost_text(1.9, 1.7, 2.1, "plain auto") == "1.90x the time of plain auto (pairs 1.70-2.10x)"


def test_a_ratio_whose_pairs_disagree_is_not_a_verdict():
    for text in (ratio_text(2.5, 0.9, 6.0, "faster", "slower", "reference"), cost_text(0.5, 0.4, 1.3, "plain auto")):
        assert "cannot tell which is faster" in text and "x faster" not in text
    assert not Paired((1, 1, 1), (1, 1, 1), 1.0, 0.9, 1.1).decided
    assert Paired((1, 1, 1), (2, 2, 2), 2.0, 1.8, 2.2).decided


def test_pairs_run_in_turn_and_count_every_call():
    calls = []
    result = paired(lambda: calls.append("a"), lambda: calls.append("b"), 3)
    assert calls == ["a", "b"] + ["a", "b"] * 3  # one warm-up each, then alternately
    assert result.ratio_lo <= result.ratio <= result.ratio_hi


def test_a_ratio_whose_pairs_range_too_wide_says_so_beside_the_figure():
    text = ratio_text(4.9, 3.0, 6.0, "faster", "slower", "reference")
    assert text.startswith("4.9x faster (pairs 3.0-6.0x; ") and "factor of 2.0" in text and "cannot support" in text
    text = cost_text(3.56, 2.18, 8.68, "plain auto")
    assert text.startswith("3.56x the time of plain auto (pairs 2.18-8.68x; ") and "cannot support" in text
    assert ratio_text(0.25, 0.2, 0.4, "faster", "slower").startswith("4.0x slower (pairs 2.5-5.0x; ")


def test_a_turn_of_a_pair_calls_again_until_its_least_time_and_counts_the_mean_call():
    import time

    calls = []

    def a():
        calls.append("a")
        time.sleep(0.004)

    result = paired(a, lambda: calls.append("b"), 2, warm_up=False, min_seconds=0.02)
    assert calls.count("b") > calls.count("a") >= 2  # b is far quicker: called far more in its turns
    assert result.a[0] >= 0.004 and result.b[0] < 0.004  # the mean call of each
