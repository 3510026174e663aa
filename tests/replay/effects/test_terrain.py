"""The hull bottom and the terrain's edge along the motion: a mound between the tracks, a hole in the terrain."""

from tests.replay.scenes import GROUND, flat, replay_csv, scene


def test_the_hull_bottom_scrapes_over_a_mound_between_the_tracks(run, tmp_path):
    def mound(z, x0, y0):  # 0.8 m high, 2 m long, 1 m wide: between the tracks (inner edges 1.1 m out)
        rows, cols = z.shape
        for r in range(rows):
            for c in range(cols):
                x, y = x0 + c, y0 + (rows - 1 - r)
                if 49 <= x <= 51 and abs(y - 30) <= 0.5:
                    z[r, c] = GROUND + 0.8

    flat(tmp_path, bump=mound)
    scene(tmp_path)
    result, events, summary = replay_csv(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n1,60,30,0\n")
    assert result.exit_code == 0, result.stderr
    terrain = [e for e in events if e["kind"] == "terrain"]
    assert len(terrain) == 1 and terrain[0]["between"] and terrain[0]["step"] == 0
    assert 0.01 < terrain[0]["depth"] <= 0.8 - 0.49 + 1e-6  # at onset, on the mound's flank at the most
    # the hull's front edge reaches the mound's first posts after about (49 - 3.43 - 40) / 20 of the second
    assert (49 - 3.43 - 1 - 40) / 20 <= terrain[0]["t"] <= (51 + 3.43 - 40) / 20
    assert summary["motion"]["substep_travel_m"] == 0.5 and summary["motion"]["substeps"] == 39


def test_a_path_leaving_the_terrain_between_rows(run, tmp_path):
    def hole(z, x0, y0):
        z[20:40, 55:65] = -9999.0

    flat(tmp_path, bump=hole)
    (tmp_path / "ground.asc").write_text((tmp_path / "ground.asc").read_text().replace(
        "cellsize 1.0\n", "cellsize 1.0\nNODATA_value -9999\n"))
    scene(tmp_path)
    _, events, summary = replay_csv(run, tmp_path, "t,x,y,yaw_deg\n0,40,30,0\n2,80,30,0\n")
    off = [e for e in events if e["kind"] == "off_terrain"]
    assert len(off) == 1 and off[0]["between"] and off[0]["step"] == 0
    assert 0 < off[0]["t"] < 2 and summary["between"]["off_terrain"] == 1
