"""The HTTP contract's request and response models (``docs/api.md``), one class per direction.

Pure pydantic: nothing here imports the planner, so clients can reuse these models as they are.
"""

from schemas.errors import ErrorPublic
from schemas.examples import EXAMPLE_MAP, EXAMPLE_MAP_ID
from schemas.fleet_names import PlanCreate
from schemas.fleets import FleetPublic, FleetRobotPublic, FleetSolvePublic
from schemas.mapf import MapfAgent, MapfCreate, MapfPublic, PlanGoalUpdate
from schemas.maps import MULTIPART_FIELDS, MapCreate, MapPublic
from schemas.ops import LivePublic, PoolStats, ReadyPublic
from schemas.passages import NarrowestPublic, PassagePublic, PassagesPublic
from schemas.paths import FRAME_ID_MAX, FRAME_ID_PATTERN, NavPath
from schemas.plans import (
    PRESET_NAMES,
    AnalysisPublic,
    DetourPublic,
    PlanDetail,
    PlanPublic,
    Preset,
    PreviewPublic,
    TrajectoryMetrics,
)
from schemas.points import UNION_TAGS, Cell, CellOrPoint, Circle, Obstacle, Point, Pose
from schemas.scans import (
    LaserScan,
    LiveMarksPublic,
    ObservationCreate,
    ObservationPublic,
    ScanPose,
)
from schemas.service import CacheStats, HealthPublic, StoreHealth
from schemas.simulation import SimulationCreate, SimulationMetrics, SimulationPublic
from schemas.steps import StepCreate, StepPublic
from schemas.zones import (
    ZONES_MULTIPART,
    KeepoutMaskPublic,
    SpeedZoneCreate,
    SpeedZonePublic,
    ZonePoint,
    ZonesCreate,
    ZonesPublic,
)

__all__ = [
    "EXAMPLE_MAP",
    "EXAMPLE_MAP_ID",
    "FRAME_ID_MAX",
    "FRAME_ID_PATTERN",
    "MULTIPART_FIELDS",
    "PRESET_NAMES",
    "UNION_TAGS",
    "ZONES_MULTIPART",
    "AnalysisPublic",
    "CacheStats",
    "Cell",
    "CellOrPoint",
    "Circle",
    "DetourPublic",
    "ErrorPublic",
    "FleetPublic",
    "FleetRobotPublic",
    "FleetSolvePublic",
    "HealthPublic",
    "KeepoutMaskPublic",
    "LaserScan",
    "LiveMarksPublic",
    "LivePublic",
    "MapCreate",
    "MapPublic",
    "MapfAgent",
    "MapfCreate",
    "MapfPublic",
    "NarrowestPublic",
    "NavPath",
    "ObservationCreate",
    "ObservationPublic",
    "Obstacle",
    "PassagePublic",
    "PassagesPublic",
    "PlanCreate",
    "PlanDetail",
    "PlanGoalUpdate",
    "PlanPublic",
    "Point",
    "PoolStats",
    "Pose",
    "Preset",
    "PreviewPublic",
    "ReadyPublic",
    "ScanPose",
    "SimulationCreate",
    "SimulationMetrics",
    "SimulationPublic",
    "SpeedZoneCreate",
    "SpeedZonePublic",
    "StepCreate",
    "StepPublic",
    "StoreHealth",
    "TrajectoryMetrics",
    "ZonePoint",
    "ZonesCreate",
    "ZonesPublic",
]
