"""
Files in and out: scenes from NumPy stacks, EXR frame sequences and FEA nodal exports (by
suffix: :func:`read_scene`, with the registry of scene types :data:`SCENE_TYPES`);
measurements to and from multi-channel EXR, and to and from labelled xarray datasets and NetCDF;
a camera's recordings by file type (:func:`read_recording`, :data:`RECORDING_READERS`).

Every reader states units explicitly (from the file's header or the caller) and rejects what it
cannot read with an error naming the file, the line or frame, and the problem.
"""

import importlib

# The readers and writers load their module on first use (PEP 562), so that reading an EXR
# file (radiosim.io.exr) does not import the FEA readers' scenes, scipy and numba with it.
_LAZY = {
    "read_exr": "exr", "read_exr_sequence": "exr", "write_exr": "exr",
    "write_exr_sequence": "exr",
    "read_fea_mesh": "fea", "read_fea_nodes": "fea",
    "read_frames": "frames",
    "from_xarray": "netcdf", "read_netcdf": "netcdf", "read_results": "netcdf",
    "results_to_xarray": "netcdf", "to_xarray": "netcdf", "write_netcdf": "netcdf",
    "SCENE_TYPES": "scenes", "SceneArgumentError": "scenes", "SceneType": "scenes",
    "read_scene": "scenes",
    "Recording": "recordings", "RECORDING_READERS": "recordings", "read_recording": "recordings",
}


_SUBMODULES = frozenset({"exr", "fea", "frames", "netcdf", "recordings", "scenes"})


def __getattr__(name):
    if name in _SUBMODULES:  # radiosim.io.exr after `import radiosim.io`, as before
        value = importlib.import_module(f"radiosim.io.{name}")
    elif name in _LAZY:
        value = getattr(importlib.import_module(f"radiosim.io.{_LAZY[name]}"), name)
    else:
        raise AttributeError(f"module 'radiosim.io' has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | _SUBMODULES)


__all__ = [
    "read_scene",
    "read_recording",
    "Recording",
    "RECORDING_READERS",
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
