"""
Reading scenes from files: NumPy stacks, EXR frame sequences and FEA nodal exports.

Every reader states units explicitly (from the file's header or the caller) and rejects what it
cannot read with an error naming the file, the line or frame, and the problem.
"""

from radiosim.io.fea import read_fea_nodes
from radiosim.io.frames import read_frames

__all__ = ["read_frames", "read_fea_nodes"]
