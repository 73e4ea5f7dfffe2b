"""
Files in and out: scenes from NumPy stacks, EXR frame sequences and FEA nodal exports (by
suffix: :func:`read_scene`, with the registry of scene types :data:`SCENE_TYPES`);
measurements to and from multi-channel EXR, and to and from labelled xarray datasets and NetCDF.

Every reader states units explicitly (from the file's header or the caller) and rejects what it
cannot read with an error naming the file, the line or frame, and the problem.
"""

from radiosim.io.exr import read_exr, read_exr_sequence, write_exr, write_exr_sequence
from radiosim.io.fea import read_fea_mesh, read_fea_nodes
from radiosim.io.frames import read_frames
from radiosim.io.netcdf import (from_xarray, read_netcdf, read_results, results_to_xarray,
                                to_xarray, write_netcdf)
from radiosim.io.scenes import SCENE_TYPES, SceneArgumentError, SceneType, read_scene

__all__ = [
    "read_scene",
    "SCENE_TYPES",
    "SceneType",
    "SceneArgumentError",
    "read_frames",
    "read_fea_nodes",
    "read_fea_mesh",
    "write_exr",
    "read_exr",
    "write_exr_sequence",
    "read_exr_sequence",
    "to_xarray",
    "from_xarray",
    "write_netcdf",
    "read_netcdf",
    "results_to_xarray",
    "read_results",
]
