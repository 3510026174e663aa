"""Frames: ECEF <-> geodetic against pyproj's own transforms; grid headings against steps through pyproj and the
true azimuths of pyproj.Geod; DIS orientations built here from the definitions, decoded back."""

import numpy as np
import pytest

from tankcd_cli.errors import InputError
from tankcd_cli.io import geodesy as G

pyproj = pytest.importorskip("pyproj")


def _points(n=2000, seed=1, hmax=9000.0):
    rng = np.random.default_rng(seed)
    lon = rng.uniform(-180, 180, n)
    lat = np.degrees(np.arcsin(rng.uniform(-1, 1, n)))
    lat[:4] = [90.0, -90.0, 0.0, 89.999999]
    h = rng.uniform(-500, hmax, n)
    return lon, lat, h


def test_ecef_to_geodetic_matches_pyproj_to_a_millimetre():
    lon, lat, h = _points()
    fwd = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)
    x, y, z = fwd.transform(lon, lat, h)
    glon, glat, gh = G.ecef_to_geodetic(np.column_stack([x, y, z]))
    inv = pyproj.Transformer.from_crs("EPSG:4978", "EPSG:4979", always_xy=True)
    plon, plat, ph = inv.transform(x, y, z)
    # metres on the ground: latitude and longitude differences scaled by the radii
    dnorth = np.radians(glat - plat) * G.A
    deast = np.radians((glon - plon + 180) % 360 - 180) * G.A * np.cos(np.radians(plat))
    assert np.abs(dnorth).max() < 1e-3 and np.abs(deast).max() < 1e-3 and np.abs(gh - ph).max() < 1e-3
    assert np.abs(gh - h).max() < 1e-3  # and pyproj's own round trip agrees


def test_geodetic_to_ecef_matches_pyproj():
    lon, lat, h = _points(seed=2)
    x, y, z = pyproj.Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True).transform(lon, lat, h)
    np.testing.assert_allclose(G.geodetic_to_ecef(lon, lat, h), np.column_stack([x, y, z]), atol=1e-6, rtol=0)


def test_enu_basis_is_orthonormal_and_up_is_the_ellipsoid_normal():
    lon, lat, h = _points(200, seed=3)
    r = G.enu_basis(lon, lat)
    np.testing.assert_allclose(r @ r.transpose(0, 2, 1), np.broadcast_to(np.eye(3), r.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-14)
    up = G.geodetic_to_ecef(lon, lat, h + 1.0) - G.geodetic_to_ecef(lon, lat, h)
    np.testing.assert_allclose(r[:, 2], up, atol=1e-8)
    north = G.geodetic_to_ecef(lon, lat + 1e-6, h) - G.geodetic_to_ecef(lon, lat - 1e-6, h)
    np.testing.assert_allclose(r[4:, 1], north[4:] / np.linalg.norm(north[4:], axis=1)[:, None], atol=1e-8)
    v = np.random.default_rng(5).normal(size=(len(lon), 3))
    enu = G.ecef_to_enu_vectors(v, lon, lat)
    np.testing.assert_allclose(enu[:, 2], np.einsum("ij,ij->i", v, up), atol=1e-8)  # up component: along the normal
    np.testing.assert_allclose(G.enu_to_ecef_vectors(enu, lon, lat), v, atol=1e-12)


# (EPSG, longitude of the central meridian): UTM zones in both hemispheres
ZONES = [(32633, 15.0), (32733, 15.0), (32617, -81.0), (32756, 153.0), (32631, 3.0)]


def _cases():
    for epsg, cm in ZONES:
        south = epsg > 32700
        for dlon in (-3.0, -2.999, 0.0, 1.5, 3.0):
            for lat in ((-45.0, -0.25, -60.0, -79.5) if south else (45.0, 0.25, 60.0, 83.5)):
                yield epsg, cm + dlon, lat


CASES = list(_cases())


def _crs_wkt(epsg):
    return pyproj.CRS.from_epsg(epsg).to_wkt()


@pytest.mark.parametrize("epsg", sorted({c[0] for c in CASES}))
def test_a_step_along_the_grid_yaw_has_the_true_heading(epsg):
    """At zone edges (3 deg from the central meridian, where the convergence is 2-3 deg at mid
    latitudes), the equator and high latitudes: 1 m along grid_yaw in the CRS, back to lon/lat with
    pyproj, has Geod.inv's true azimuth = the heading given, to 1e-6 deg."""
    cases = [c for c in CASES if c[0] == epsg]
    rng = np.random.default_rng(epsg)
    lon = np.repeat([c[1] for c in cases], 12)
    lat = np.repeat([c[2] for c in cases], 12)
    heading = np.radians(np.concatenate([[0, 90, 180, 270, 359.9999], rng.uniform(0, 360, len(lon) - 5)]))
    wkt = _crs_wkt(epsg)
    x, y, gyaw = G.to_terrain_crs(lon, lat, wkt, heading=heading)
    back = pyproj.Transformer.from_crs(wkt, "EPSG:4326", always_xy=True)
    lon0, lat0 = back.transform(x, y)
    np.testing.assert_allclose(lon0, lon, atol=1e-9)
    np.testing.assert_allclose(lat0, lat, atol=1e-9)
    lon1, lat1 = back.transform(x + np.cos(gyaw), y + np.sin(gyaw))
    az, _, dist = pyproj.Geod(ellps="WGS84").inv(lon0, lat0, lon1, lat1)
    err = (az - np.degrees(heading) + 180) % 360 - 180
    assert np.abs(err).max() < 1e-6, np.abs(err).max()
    assert 0.99 < dist.min() and dist.max() < 1.01  # the scale factor near 1


def test_the_convergence_is_pyprojs_meridian_convergence_with_its_sign():
    lon = np.array([c[1] for c in CASES])
    lat = np.array([c[2] for c in CASES])
    for epsg in sorted({c[0] for c in CASES}):
        k = np.array([c[0] == epsg for c in CASES])
        wkt = _crs_wkt(epsg)
        ours = np.degrees(G.meridian_convergence(lon[k], lat[k], wkt))
        theirs = pyproj.Proj(pyproj.CRS.from_epsg(epsg)).get_factors(lon[k], lat[k]).meridian_convergence
        np.testing.assert_allclose(ours, theirs, atol=1e-6)
        # the sign: true north counter-clockwise of grid north east of the central meridian in the
        # north, west of it in the south; and the size at a zone's edge at 45 deg: about 2.1 deg
        cm = dict(ZONES)[epsg]
        east = lon[k] > cm + 1e-9
        north = lat[k] > 0
        assert (np.sign(ours[east]) == np.where(north[east], 1, -1)).all()
        edge = east & (np.abs(np.abs(lat[k]) - 45) < 1e-9) & (np.abs(lon[k] - cm - 3) < 1e-9)
        if edge.any():
            assert np.abs(ours[edge]) == pytest.approx(2.1223, abs=1e-3)
    # an ENU yaw is the heading's: grid_yaw = enu_yaw + convergence
    wkt = _crs_wkt(32633)
    yaw = np.radians([0.0, 33.0, -120.0])
    g1 = G.grid_yaw(np.full(3, 18.0), np.full(3, 45.0), wkt, enu_yaw=yaw)
    np.testing.assert_allclose(G.wrap_angle(g1 - yaw), np.radians(2.122299717), atol=1e-9)
    g2 = G.grid_yaw(np.full(3, 18.0), np.full(3, 45.0), wkt, heading=G.enu_yaw_to_heading(yaw))
    np.testing.assert_allclose(g1, g2, atol=1e-12)


def test_a_terrain_without_a_crs_is_refused_naming_the_input():
    with pytest.raises(InputError, match=r"^track\.gpx: geographic input needs a terrain with a CRS"):
        G.to_terrain_crs(np.array([10.0]), np.array([50.0]), "", heading=np.zeros(1), source="track.gpx")
    with pytest.raises(InputError, match=r"track\.csv: .*projected CRS.*geographic"):
        G.to_terrain_crs(np.array([10.0]), np.array([50.0]), pyproj.CRS.from_epsg(4326).to_wkt(), heading=np.zeros(1),
                         source="track.csv")


# -- orientation -------------------------------------------------------------------------------------------
def _rot(axis, a):
    """A rotation about a coordinate axis by the right-hand rule, from the definition."""
    c, s = np.cos(a), np.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def _dis_euler_from_enu(yaw, pitch, roll, lon, lat):
    """The DIS (psi, theta, phi) of a vehicle with REP 103 attitude (yaw from east, pitch, roll) in local
    ENU at (lon, lat), built from the definitions: the vehicle's axes in ENU, then in ECEF by the ENU
    unit vectors written out, then the z-y-x Euler angles of the body (x fwd, y right, z down)."""
    lam, phi_ = np.radians(lon), np.radians(lat)
    east = np.array([-np.sin(lam), np.cos(lam), 0])
    north = np.array([-np.sin(phi_) * np.cos(lam), -np.sin(phi_) * np.sin(lam), np.cos(phi_)])
    up = np.array([np.cos(phi_) * np.cos(lam), np.cos(phi_) * np.sin(lam), np.sin(phi_)])
    vehicle_in_enu = _rot(2, yaw) @ _rot(1, pitch) @ _rot(0, roll)  # columns: forward, left, up
    body_in_enu = vehicle_in_enu @ np.diag([1.0, -1.0, -1.0])        # forward, right, down
    body_in_ecef = np.column_stack([east, north, up]) @ body_in_enu
    # R = Rz(psi) Ry(theta) Rx(phi): R[2,0] = -sin(theta), R[1,0]/R[0,0] = tan(psi), R[2,1]/R[2,2] = tan(phi)
    theta = -np.arcsin(body_in_ecef[2, 0])
    psi = np.arctan2(body_in_ecef[1, 0], body_in_ecef[0, 0])
    phi = np.arctan2(body_in_ecef[2, 1], body_in_ecef[2, 2])
    assert np.allclose(_rot(2, psi) @ _rot(1, theta) @ _rot(0, phi), body_in_ecef)
    return psi, theta, phi


def test_a_dis_orientation_built_from_a_known_attitude_decodes_back():
    rng = np.random.default_rng(9)
    n = 500
    lon = rng.uniform(-180, 180, n)
    lat = rng.uniform(-85, 85, n)
    yaw = rng.uniform(-np.pi, np.pi, n)
    pitch = rng.uniform(-0.6, 0.6, n)
    roll = rng.uniform(-0.6, 0.6, n)
    dis = np.array([_dis_euler_from_enu(*a) for a in zip(yaw, pitch, roll, lon, lat)])
    y2, p2, r2 = G.dis_orientation_to_enu(dis[:, 0], dis[:, 1], dis[:, 2], lon, lat)
    np.testing.assert_allclose(G.wrap_angle(y2 - yaw), 0, atol=1e-9)
    np.testing.assert_allclose(p2, pitch, atol=1e-9)
    np.testing.assert_allclose(r2, roll, atol=1e-9)


def test_dis_orientation_hand_cases():
    """At lon 0, lat 0 (east = ECEF +y, north = +z, up = +x): a level vehicle facing east has its body x
    on +y and its body z (down) on -x: psi 90 deg, theta 0, phi -90 deg (derived by hand)."""
    y, p, r = G.dis_orientation_to_enu(np.radians([90.0]), [0.0], np.radians([-90.0]), [0.0], [0.0])
    np.testing.assert_allclose([y[0], p[0], r[0]], [0, 0, 0], atol=1e-12)
    # facing north at the equator: body x = ECEF +z (theta = -90: the DIS angles' gimbal lock) is fine
    psi, theta, phi = _dis_euler_from_enu(np.pi / 2, 0.0, 0.0, 0.0, 0.0)
    y, p, r = G.dis_orientation_to_enu([psi], [theta], [phi], [0.0], [0.0])
    np.testing.assert_allclose([y[0], p[0], r[0]], [np.pi / 2, 0, 0], atol=1e-7)
    # nose up (REP 103: negative pitch) and right side down (positive roll) keep their signs
    psi, theta, phi = _dis_euler_from_enu(0.3, -0.1, 0.05, 10.0, 50.0)
    y, p, r = G.dis_orientation_to_enu([psi], [theta], [phi], [10.0], [50.0])
    np.testing.assert_allclose([y[0], p[0], r[0]], [0.3, -0.1, 0.05], atol=1e-12)


def test_dis_to_terrain_in_a_utm_zone():
    wkt = _crs_wkt(32632)  # zone 32: CM 9E
    lon, lat = np.array([11.5, 6.2]), np.array([48.1, 52.3])
    yaw, pitch, roll = np.array([0.4, -2.0]), np.array([-0.05, 0.1]), np.array([0.02, -0.03])
    dis = np.array([_dis_euler_from_enu(*a) for a in zip(yaw, pitch, roll, lon, lat)])
    loc = G.geodetic_to_ecef(lon, lat, [300.0, 45.0])
    out = G.dis_to_terrain(loc, dis, wkt)
    x, y = pyproj.Transformer.from_crs("EPSG:4326", wkt, always_xy=True).transform(lon, lat)
    np.testing.assert_allclose(out["x"], x, atol=1e-6)
    np.testing.assert_allclose(out["y"], y, atol=1e-6)
    np.testing.assert_allclose(out["h"], [300.0, 45.0], atol=1e-6)
    conv = np.radians(pyproj.Proj(pyproj.CRS.from_epsg(32632)).get_factors(lon, lat).meridian_convergence)
    np.testing.assert_allclose(G.wrap_angle(out["grid_yaw"] - yaw - conv), 0, atol=1e-8)
    np.testing.assert_allclose(out["pitch"], pitch, atol=1e-9)
    np.testing.assert_allclose(out["roll"], roll, atol=1e-9)
