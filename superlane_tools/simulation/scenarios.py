"""Named drive scenarios: a road recipe, traffic, roadside scenery and conditions each."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.motion import TrafficRecipe
from superlane_tools.simulation.road import RoadRecipe
from superlane_tools.simulation.roadside import RoadsideRecipe
from superlane_tools.simulation.scene import Conditions


@dataclass(frozen=True)
class Scenario:
    """One named drive scenario.

    Attributes:
        name: Scenario name (``slt simulate --scenario NAME``).
        description: One-line description.
        road: How the road is generated.
        traffic: How the ego vehicle drives and the traffic around it.
        roadside: Scenery beside the road.
        conditions: Lighting, weather and sensor effects.
        lane_quality: Mobileye-style lane quality (0-3) the simulated sensor reports nominally.
    """

    name: str
    description: str
    road: RoadRecipe = field(default_factory=RoadRecipe)
    traffic: TrafficRecipe = field(default_factory=TrafficRecipe)
    roadside: RoadsideRecipe = field(default_factory=RoadsideRecipe)
    conditions: Conditions = field(default_factory=Conditions)
    lane_quality: int = 3


_HIGHWAY = RoadRecipe(lane_widths_m=(3.7, 3.7, 3.7), hilliness=0.1)
_TRAFFIC = TrafficRecipe(speed_mps=27.0, ego_lanes=(1,), leader=True, leader_gap_m=40.0)

_ALL: tuple[Scenario, ...] = (
    Scenario(
        "highway_straight",
        "Three-lane US highway, straight and nearly flat, preceding vehicle and a cut-in.",
        road=_HIGHWAY,
        traffic=replace(_TRAFFIC, cut_in=True),
        conditions=Conditions(name="highway_straight"),
    ),
    Scenario(
        "highway_curves",
        "Three-lane highway with clothoid curves up to 1/150 1/m, a hill and lane changes.",
        road=replace(_HIGHWAY, curviness=1.0, hilliness=0.6),
        traffic=replace(_TRAFFIC, ego_lanes=(0, 1, 2), lane_change_every_m=350.0),
        conditions=Conditions(name="highway_curves", sun_elevation_deg=35.0),
    ),
    Scenario(
        "hills",
        "Two-lane rural road with crests and sags up to +-8 % grade and gentle curves.",
        road=RoadRecipe(
            lane_widths_m=(3.5, 3.5),
            curviness=0.5,
            hilliness=1.0,
            left_color="white",
            shoulder_m=1.0,
        ),
        traffic=replace(_TRAFFIC, speed_mps=20.0, ego_lanes=(0, 1), lane_change_every_m=500.0),
        roadside=RoadsideRecipe(trees_per_100m=6.0, guard_rails=False),
        conditions=Conditions(name="hills"),
    ),
    Scenario(
        "stop_and_go",
        "Two-lane arterial with traffic lights: stops of 20-90 s after a crawl, pulling away.",
        road=RoadRecipe(
            lane_widths_m=(3.5, 3.5),
            curviness=0.4,
            hilliness=0.2,
            left_color="white",
            shoulder_m=0.5,
        ),
        traffic=replace(
            _TRAFFIC,
            speed_mps=14.0,
            speed_variation_mps=2.0,
            ego_lanes=(0,),
            leader_gap_m=30.0,
            stop_every_s=25.0,
        ),
        conditions=Conditions(name="stop_and_go"),
    ),
    Scenario(
        "urban",
        "Four-lane city street with double yellow centre line, curbs, sidewalks, crosswalks.",
        road=RoadRecipe(
            lane_widths_m=(3.3, 3.3, 3.3, 3.3),
            curviness=0.2,
            hilliness=0.2,
            left_color="white",
            oncoming_lanes=2,
            shoulder_m=0.3,
            curb_height_m=0.15,
            sidewalk_m=3.0,
            intersection_spacing_m=160.0,
        ),
        traffic=TrafficRecipe(
            speed_mps=11.0,
            speed_variation_mps=3.0,
            ego_lanes=(2, 3),
            lane_change_every_m=250.0,
            leader_gap_m=20.0,
            others_per_km=30.0,
        ),
        roadside=RoadsideRecipe(
            trees_per_100m=1.0,
            bushes_per_100m=0.5,
            buildings=True,
            guard_rails=False,
            pole_spacing_m=35.0,
            signs_per_km=10.0,
            tree_distance_m=(0.5, 2.0),
        ),
        conditions=Conditions(name="urban", sun_elevation_deg=30.0, cracks=0.4),
    ),
    Scenario(
        "merge_split",
        "Highway where the right lane ends in a taper and later a lane opens again.",
        road=replace(_HIGHWAY, merge=True, curviness=0.3),
        traffic=replace(_TRAFFIC, ego_lanes=(0, 1), lane_change_every_m=400.0),
        conditions=Conditions(name="merge_split"),
    ),
    Scenario(
        "night",
        "Highway at night: headlights only, high sensor noise.",
        road=replace(_HIGHWAY, curviness=0.6),
        traffic=_TRAFFIC,
        conditions=Conditions(
            name="night", daylight=0.05, sun_elevation_deg=-20.0, noise_sigma=5.0, exposure=1.6
        ),
        lane_quality=2,
    ),
    Scenario(
        "tunnel",
        "Two-lane road tunnel with concrete surface and artificial lights.",
        road=RoadRecipe(
            lane_widths_m=(3.5, 3.5),
            curviness=0.4,
            left_color="white",
            shoulder_m=1.0,
            surface="concrete",
        ),
        traffic=replace(_TRAFFIC, speed_mps=22.0, ego_lanes=(0, 1)),
        roadside=RoadsideRecipe(0.0, 0.0, False, False, 0.0, 0.0),
        conditions=Conditions(name="tunnel", tunnel=True, daylight=0.4, noise_sigma=3.5),
        lane_quality=2,
    ),
    Scenario(
        "sun_after_rain",
        "Wet road after rain with a low sun ahead: strong reflections on the asphalt.",
        road=replace(_HIGHWAY, curviness=0.4),
        traffic=_TRAFFIC,
        conditions=Conditions(
            name="sun_after_rain", wet=0.8, sun_elevation_deg=8.0, glare=0.5, exposure=1.1
        ),
        lane_quality=2,
    ),
    Scenario(
        "heavy_rain",
        "Heavy rain: streaks, droplets, spray from vehicles, haze and a dark wet road.",
        road=replace(_HIGHWAY, curviness=0.4),
        traffic=replace(_TRAFFIC, speed_mps=22.0, leader_gap_m=35.0),
        conditions=Conditions(
            name="heavy_rain",
            daylight=0.5,
            wet=1.0,
            rain=0.9,
            fog=0.35,
            motion_blur_px=3.0,
            noise_sigma=3.0,
            jpeg_quality=80,
        ),
        lane_quality=1,
    ),
    Scenario(
        "direct_sunlight",
        "Driving into a low sun: glare, lens flare and washed-out contrast.",
        road=replace(_HIGHWAY, curviness=0.3),
        traffic=_TRAFFIC,
        conditions=Conditions(
            name="direct_sunlight", sun_elevation_deg=5.0, glare=0.9, exposure=1.3
        ),
        lane_quality=1,
    ),
    Scenario(
        "faded_lines",
        "Worn, partly missing lane markings with European 6 m / 12 m dashes.",
        road=replace(
            _HIGHWAY, curviness=0.5, wear=0.65, dash_m=6.0, gap_m=12.0, left_color="white"
        ),
        traffic=_TRAFFIC,
        conditions=Conditions(name="faded_lines", cracks=0.5),
        lane_quality=1,
    ),
    Scenario(
        "tar_seams",
        "Concrete-coloured asphalt crossed by dark tar sealant lines that mimic lane edges.",
        road=replace(_HIGHWAY, curviness=0.5),
        traffic=_TRAFFIC,
        conditions=Conditions(name="tar_seams", tar_seams=0.9, cracks=0.6),
        lane_quality=2,
    ),
)

SCENARIOS: dict[str, Scenario] = {s.name: s for s in _ALL}
"""All scenarios by name, in presentation order."""


def get_scenario(name: str) -> Scenario:
    """Return the scenario called ``name``.

    Raises:
        ScenarioError: If there is no scenario with that name.
    """
    try:
        return SCENARIOS[name]
    except KeyError:
        known = ", ".join(SCENARIOS)
        raise ScenarioError(f"unknown scenario {name!r} (known: {known})") from None


def scenario_names() -> tuple[str, ...]:
    """Return the scenario names in presentation order."""
    return tuple(SCENARIOS)
