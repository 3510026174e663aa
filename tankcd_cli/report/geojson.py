"""A replay's tracks and events as GeoJSON (RFC 7946): longitude, latitude in WGS 84, for QGIS,
geopandas, kepler.gl (docs/formats.md, "Outputs for review").

Written feature by feature (an event a Point, a vehicle's piece of motion a LineString), the
coordinates of a track formatted a chunk of rows at a time: memory follows the longest chunk,
not the file.
"""

from __future__ import annotations

import numpy as np

from tankcd_cli.report import places

DEG_DECIMALS = 8  # 1e-8 deg: about 1 mm
Z_DECIMALS = 3  # mm
T_DECIMALS = 6  # as the events' times


def write_geojson(review, path: str) -> None:
    """Write ``review`` (``report.review.Review``) to ``path`` as a GeoJSON FeatureCollection.

    Features, in this order: a Point per event (the file's order) at its ``point`` or, without
    one, at its vehicle's position at its time, with every field of the event as properties;
    then per vehicle (entity order) and per piece of motion (``places.pieces``) a LineString with
    a vertex per pose row, or a Point of kind ``position`` for a piece of one row. A terrain
    without a CRS is an InputError, and nothing is written."""
    from tankcd_cli.io.atomic import output_text

    places.require_crs(review, "GeoJSON")
    transformer = places.lonlat_transformer(review)
    with output_text(path) as fh:
        fh.write('{"type":"FeatureCollection","features":[\n')
        first = True
        lon, lat, z, own = places.event_places(review, transformer)
        for n, event in enumerate(review.events):
            if not first:
                fh.write(",\n")
            first = False
            fh.write(_event_feature(n, event, lon[n], lat[n], z[n], own[n]))
        for tr in review.tracks:
            lon, lat = places.to_lonlat(transformer, tr.x, tr.y)
            for k, (a, b) in enumerate(places.pieces(tr.t)):
                if not first:
                    fh.write(",\n")
                first = False
                _write_piece(fh, tr, k, a, b, lon, lat)
        fh.write("\n]}\n")


def _event_feature(n: int, event: dict, lon: float, lat: float, z: float, own: bool) -> str:
    geometry = "null"
    if np.isfinite(lon):
        # the event's own point keeps its height; a position found from the poses is 2D
        xyz = [lon, lat, z] if own and np.isfinite(z) else [lon, lat]
        coords = places.numbers_text(np.array([xyz]), [DEG_DECIMALS, DEG_DECIMALS, Z_DECIMALS][:len(xyz)])
        geometry = f'{{"type":"Point","coordinates":[{coords}]}}'
    return f'{{"type":"Feature","id":"event/{n}","geometry":{geometry},"properties":{places.json_text(event)}}}'


def _write_piece(fh, tr, k: int, a: int, b: int, lon: np.ndarray, lat: np.ndarray) -> None:
    """One piece of a track (rows a:b) as a Feature: LineString (>= 2 rows) or Point (1 row)."""
    rows = slice(a, b)
    z = tr.z[rows]
    has_z = bool(np.isfinite(z).all())
    cols = [lon[rows], lat[rows]] + ([z] if has_z else [])
    decimals = [DEG_DECIMALS, DEG_DECIMALS] + ([Z_DECIMALS] if has_z else [])
    coords = np.column_stack(cols)
    entity = places.json_text(tr.entity)
    one = b - a == 1
    fh.write(f'{{"type":"Feature","id":{places.json_text(f"vehicle/{tr.entity}/{k}")},"geometry":')
    if one:
        fh.write('{"type":"Point","coordinates":[')
        places.write_numbers(fh, coords, decimals)
        fh.write("]}")
    else:
        fh.write('{"type":"LineString","coordinates":[[')
        places.write_numbers(fh, coords, decimals, row_sep="],[")
        fh.write("]]}")
    t = tr.t[rows]
    t_start, t_end = (places.json_text(float(np.nanmin(t))), places.json_text(float(np.nanmax(t)))) \
        if np.isfinite(t).any() else ("null", "null")
    fh.write(f',"properties":{{"kind":"{"position" if one else "track"}","entity":{entity},"piece":{k},'
             f'"t_start":{t_start},"t_end":{t_end},"steps":[')
    places.write_numbers(fh, tr.step[rows].astype(np.float64), 0)
    fh.write('],"times":[')
    places.write_numbers(fh, t, T_DECIMALS)
    fh.write("]}}")
