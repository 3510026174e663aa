"""tankcd tradeoff: what its help promises."""


def test_quick_help_promises_no_stale_seconds(run):
    text = " ".join(run("tradeoff", "--help").stdout.split())
    assert "Small inputs, 3 repeats and 7 pairs behind each ratio, without the matcher corpus, for CI: well under " \
           "a minute on 2 cores (the full run takes several minutes)." in text
    assert "a few seconds" not in text
