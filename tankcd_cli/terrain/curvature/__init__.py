"""Signed mean curvature at the vertices of a terrain mesh: ``mean.mean_curvature`` runs one of
the estimators (``cotan``, ``sphere``, ``jet``), each beside its compiled passes (``one_ring``,
``jet_fit``) and tested against them."""
