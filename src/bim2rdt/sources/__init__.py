"""Real sensor data in: frame readers behind one seam, and registered scans.

``open_recording(path, **options)`` decides what a path holds (a ROS bag, a scan, camera frames) and returns a
:class:`Recording`, subsampled, that also reports what its source dropped and warned about: what ``bim2rdt
verify`` reads.
``open_source(path, **options)`` returns a :class:`FrameSource` (an iterable of perception frames) for a TUM
RGB-D folder, a colour + depth PNG pair, an Azure Kinect ``.mkv``, an organised ``.pcd`` or PCL grabber TIFFs;
``read_cloud(path)`` reads a scan (``.pcd`` ``.ply`` ``.las`` ``.laz`` ``.e57``) as a :class:`Cloud`. Both raise
:class:`SourceError` in one line naming the file. ``correct_depth`` is the depth calibration every frame reader
applies with ``depth_correction=(gx, gy, gz)``. Every reader checks what a header declares against the file's
size and a memory cap (``SourcesConfig``; ``memory_cap``/``limit_memory`` set it) before it allocates.
"""

from bim2rdt.sources.budget import SourcesConfig, limit_memory, memory_cap
from bim2rdt.sources.calibration import correct_depth, correct_points
from bim2rdt.sources.cloud import Cloud, read_cloud
from bim2rdt.sources.errors import SourceError
from bim2rdt.sources.options import SourceOptions
from bim2rdt.sources.recording import Recording, RecordingKind, as_recording, is_rosbag, open_recording
from bim2rdt.sources.source import FrameSource, open_source
from bim2rdt.sources.tf import translation_quaternion
from bim2rdt.sources.bag_writer import BagWriter

__all__ = ["as_recording", "BagWriter", "Cloud", "correct_depth", "correct_points", "FrameSource", "is_rosbag",
           "limit_memory", "memory_cap", "open_recording", "open_source", "read_cloud", "Recording", "RecordingKind",
           "SourceError", "SourceOptions", "SourcesConfig", "translation_quaternion"]
