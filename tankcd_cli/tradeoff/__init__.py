"""What accuracy costs in time: every variant of every stage on the same inputs, against an independent truth.

``stages`` runs the stages and returns records (one per variant and measure)
plus one (time, error) point per variant for the plots, timed by ``timing``
and against the peer libraries in ``peers``; ``measure`` holds the sampling-rate
stage and the grouping of a replay's events into contacts; ``report`` runs them
and writes ``tradeoff.md``, ``tradeoff.csv`` and ``tradeoff.png``; ``corpus``
generates the terrain families that decide ``auto``'s rule.
"""
