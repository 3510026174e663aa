"""The tolerances live in tolerances.py; the compiled kernels' copies are held to them."""

from tankcd_cli import tolerances as T


def test_compiled_copies_equal_the_documented_values():
    from tankcd_cli.geometry._triangles import REL_EPS
    from tankcd_cli.terrain.grid.post_queries import BARY_EPS as GRID_BARY_EPS
    from tankcd_cli.terrain.mesh.point_queries import BARY_EPS as MESH_BARY_EPS

    assert REL_EPS == T.TRIANGLE_REL_EPS
    assert GRID_BARY_EPS == MESH_BARY_EPS == T.BARY_EPS


def test_users_take_the_one_value():
    from tankcd_cli.matching import match
    from tankcd_cli.replay.effects import terrain

    assert match.EPS_XY is T.EPS_XY
    assert terrain.HULL_CONTACT is T.HULL_CONTACT
    assert match.ESCALATION_ATTITUDE_DEG is T.ESCALATION_ATTITUDE_DEG
    assert match.ATTITUDE_TOLERANCE_DEG is T.ATTITUDE_TOLERANCE_DEG
