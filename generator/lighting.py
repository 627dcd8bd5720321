"""Scene lighting of a sample: one draw of a scene's sun, sky and area lights (numpy only).

:func:`sample_lighting` draws a :class:`Lighting` from a scene spec's lighting ranges with
the sample's own ``numpy.random.Generator``; :func:`blackbody_rgb` turns a colour
temperature into linear RGB. Re-exported by :mod:`generator.sampling`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .specs import SceneSpec

__all__ = ["Lighting", "blackbody_rgb", "sample_lighting"]


def blackbody_rgb(kelvin: float) -> tuple[float, float, float]:
    """Approximate linear RGB of a black body, normalised to max 1 (Tanner Helland's fit)."""
    t = kelvin / 100.0
    if t <= 66:
        r = 255.0
        g = 99.4708025861 * math.log(t) - 161.1195681661
        b = 0.0 if t <= 19 else 138.5177312231 * math.log(t - 10) - 305.0447927307
    else:
        r = 329.698727446 * (t - 60) ** -0.1332047592
        g = 288.1221695283 * (t - 60) ** -0.0755148492
        b = 255.0
    srgb = np.clip(np.array([r, g, b]) / 255.0, 0, 1)
    lin = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    lin = lin / lin.max()
    return tuple(float(round(v, 6)) for v in lin)


@dataclass(frozen=True)
class Lighting:
    """One draw of a scene's lighting (shared by all elevations of a sample)."""

    sun_elevation: float          # radians; NaN without a sun
    sun_azimuth: float            # radians, direction *towards* the sun, CCW from +X
    sun_strength: float           # W/m^2 (Blender sun strength); 0 without a sun
    sun_color: tuple
    sun_angle: float              # angular diameter, radians (shadow softness)
    sky_strength: float
    sky_horizon: tuple
    sky_zenith: tuple
    area_strengths: tuple         # W, per area light of the scene
    area_colors: tuple
    exposure: float

    def to_columns(self) -> dict:
        def rgb(c):
            return ",".join(f"{v:.4f}" for v in c)
        return {"sun_elevation": self.sun_elevation, "sun_azimuth": self.sun_azimuth,
                "sun_strength": self.sun_strength, "sun_color": rgb(self.sun_color),
                "sky_strength": self.sky_strength, "sky_horizon": rgb(self.sky_horizon),
                "sky_zenith": rgb(self.sky_zenith),
                "area_light_strength": float(np.sum(self.area_strengths)),
                "n_area_lights": len(self.area_strengths), "exposure": self.exposure}


def sample_lighting(spec: SceneSpec, rng: np.random.Generator) -> Lighting:
    L = spec.lighting
    if L.sun is not None:
        el = math.radians(rng.uniform(*L.sun.elevation_deg))
        az = math.radians(rng.uniform(*L.sun.azimuth_deg)) % (2 * math.pi)
        strength = float(rng.uniform(*L.sun.strength))
        color = blackbody_rgb(rng.uniform(*L.sun.temperature))
        angle = math.radians(L.sun.angle_deg)
    else:
        el, az, strength, color, angle = math.nan, math.nan, 0.0, (1.0, 1.0, 1.0), 0.0
    tint = np.clip(1.0 + rng.normal(0, L.sky.tint, 3), 0.5, 1.5)
    horizon = tuple(float(v) for v in np.clip(np.array(L.sky.horizon) * tint, 0, 1))
    zenith = tuple(float(v) for v in np.clip(np.array(L.sky.zenith) * tint, 0, 1))
    sky = float(rng.uniform(*L.sky.strength))
    global_scale = rng.uniform(0.7, 1.3)
    area_s = tuple(float(rng.uniform(*a.strength) * global_scale) for a in L.area_lights)
    area_c = tuple(blackbody_rgb(rng.uniform(*a.temperature)) for a in L.area_lights)
    exposure = float(rng.uniform(*L.exposure))
    return Lighting(el, az, strength, color, angle, sky, horizon, zenith, area_s, area_c,
                    exposure)
