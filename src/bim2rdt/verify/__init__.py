"""``verify``: a real recording or scan localized on its BIM, each planned object in view checked by its own
body, judged on every frame that saw it, new objects found (people and things that moved kept apart), all
recorded into a twin and exported (``bim2rdt verify``)."""

from bim2rdt.verify.chain import FrameResult, VerifyConfig, VerifyResult, real_sensor_localization, verify_frames
from bim2rdt.verify.depth_check import DepthCheck, DepthCheckConfig, check_depth
from bim2rdt.verify.errors import VerifyError
from bim2rdt.verify.faces import PlanarFaces, PlanarFacesConfig
from bim2rdt.verify.fusion import FusedElement, FusionConfig
from bim2rdt.verify.new_objects import NewCluster, NewObjectConfig
from bim2rdt.verify.outputs import VerifyFiles, record_twin, write_outputs
from bim2rdt.verify.planned import PlannedConfig
from bim2rdt.verify.priors import heading_deg, levelled, prior_pose, read_prior_file
from bim2rdt.verify.transient import TransientConfig

__all__ = ["DepthCheck", "DepthCheckConfig", "FrameResult", "FusedElement", "FusionConfig", "NewCluster",
           "NewObjectConfig", "PlanarFaces", "PlanarFacesConfig", "PlannedConfig", "TransientConfig", "VerifyConfig",
           "VerifyError", "VerifyFiles", "VerifyResult", "check_depth", "heading_deg", "levelled", "prior_pose",
           "read_prior_file", "real_sensor_localization", "record_twin", "verify_frames", "write_outputs"]
