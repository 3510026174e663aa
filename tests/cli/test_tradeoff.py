"""tankcd tradeoff: what its help promises."""


def test_quick_help_promises_no_stale_seconds(run):
    text = " ".join(run("tradeoff", "--help").stdout.split())
    assert "Small inputs and 3 repeats, for CI: under a minute on 2 cores (the full run takes about three " \
           "times as long)." in text
    assert "a few seconds" not in text
