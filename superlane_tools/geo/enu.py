"""WGS84 geodetic coordinates to a local East-North-Up frame (pymap3d)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from superlane_tools.geo.errors import GeoError


class GeodeticOrigin(NamedTuple):
    """Origin of a local ENU frame on the WGS84 ellipsoid.

    Attributes:
        latitude_deg: Latitude, degrees north.
        longitude_deg: Longitude, degrees east.
        altitude_m: Ellipsoidal height, metres.
    """

    latitude_deg: float
    longitude_deg: float
    altitude_m: float


class EnuTrajectory(NamedTuple):
    """Positions in a local ENU frame (metres) and the origin used.

    Attributes:
        east_m: (N,) east, metres (NaN where the fix was invalid).
        north_m: (N,) north, metres.
        up_m: (N,) up, metres.
        origin: The ENU origin.
    """

    east_m: npt.NDArray[np.float64]
    north_m: npt.NDArray[np.float64]
    up_m: npt.NDArray[np.float64]
    origin: GeodeticOrigin


def valid_fixes(
    latitude_deg: npt.ArrayLike, longitude_deg: npt.ArrayLike, altitude_m: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """Return where a fix is usable: finite, within latitude/longitude ranges, not (0, 0)."""
    lat = np.asarray(latitude_deg, dtype=np.float64)
    lon = np.asarray(longitude_deg, dtype=np.float64)
    alt = np.asarray(altitude_m, dtype=np.float64)
    ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(alt)
    with np.errstate(invalid="ignore"):
        ok &= (np.abs(lat) <= 90.0) & (np.abs(lon) <= 180.0)
        ok &= ~((lat == 0.0) & (lon == 0.0))  # receivers report (0, 0) without a fix
    return ok


def parse_origin(text: str) -> GeodeticOrigin:
    """Parse ``"lat,lon,alt"`` (degrees, degrees, metres; alt optional, default 0).

    Raises:
        GeoError: If the text is not two or three numbers in range.
    """
    parts = [p.strip() for p in text.split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError as err:
        raise GeoError(
            f"origin must be 'lat,lon[,alt]' in degrees and metres, got {text!r}"
        ) from err
    if len(values) not in (2, 3):
        raise GeoError(f"origin must be 'lat,lon[,alt]' in degrees and metres, got {text!r}")
    lat, lon = values[0], values[1]
    alt = values[2] if len(values) == 3 else 0.0
    if not valid_fixes([lat], [lon], [alt])[0]:
        raise GeoError(f"origin out of range: {text!r}")
    return GeodeticOrigin(lat, lon, alt)


def geodetic_to_enu(
    latitude_deg: npt.ArrayLike,
    longitude_deg: npt.ArrayLike,
    altitude_m: npt.ArrayLike,
    origin: GeodeticOrigin | None = None,
) -> EnuTrajectory:
    """Convert WGS84 fixes to local ENU metres around ``origin`` (default: first valid fix).

    Invalid fixes (see :func:`valid_fixes`) become NaN rows; they never serve as origin.

    Args:
        latitude_deg: (N,) latitudes, degrees.
        longitude_deg: (N,) longitudes, degrees.
        altitude_m: (N,) ellipsoidal heights, metres.
        origin: ENU origin; the first valid fix when None.

    Returns:
        East, north, up in metres and the origin.

    Raises:
        GeoError: If the arrays differ in length or no fix is valid and no origin is given.
    """
    import pymap3d

    lat = np.asarray(latitude_deg, dtype=np.float64)
    lon = np.asarray(longitude_deg, dtype=np.float64)
    alt = np.asarray(altitude_m, dtype=np.float64)
    if not lat.shape == lon.shape == alt.shape or lat.ndim != 1:
        raise GeoError(f"fix arrays differ in shape: {lat.shape}, {lon.shape}, {alt.shape}")
    ok = valid_fixes(lat, lon, alt)
    if origin is None:
        if not ok.any():
            raise GeoError("no valid GNSS fix to use as ENU origin")
        first = int(np.argmax(ok))
        origin = GeodeticOrigin(float(lat[first]), float(lon[first]), float(alt[first]))
    east = np.full(lat.shape, np.nan)
    north = np.full(lat.shape, np.nan)
    up = np.full(lat.shape, np.nan)
    if ok.any():
        e, n, u = pymap3d.geodetic2enu(lat[ok], lon[ok], alt[ok], *origin)
        east[ok], north[ok], up[ok] = e, n, u
    return EnuTrajectory(east, north, up, origin)
