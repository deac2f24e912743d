"""Drive simulator: synthetic recordings (camera, CAN, RTK) with exact ground truth."""

from superlane_tools.simulation.dataset import DatasetResult, simulate_dataset
from superlane_tools.simulation.drive import DriveOutputs, DriveResult, simulate_drive
from superlane_tools.simulation.errors import ScenarioError, SimulationError
from superlane_tools.simulation.groundtruth import GT_SCHEMA, LaneTruth, lane_truth
from superlane_tools.simulation.road import Road, RoadRecipe, build_road, road_ahead
from superlane_tools.simulation.scenarios import SCENARIOS, Scenario, get_scenario
from superlane_tools.simulation.sensors import MobileyeParams, RtkParams, mobileye_to_lane_model
from superlane_tools.simulation.world import World, build_world, frame_world

__all__ = [
    "GT_SCHEMA",
    "SCENARIOS",
    "DatasetResult",
    "DriveOutputs",
    "DriveResult",
    "LaneTruth",
    "MobileyeParams",
    "Road",
    "RoadRecipe",
    "RtkParams",
    "Scenario",
    "ScenarioError",
    "SimulationError",
    "World",
    "build_road",
    "build_world",
    "frame_world",
    "get_scenario",
    "lane_truth",
    "mobileye_to_lane_model",
    "road_ahead",
    "simulate_dataset",
    "simulate_drive",
]
