"""Scenes: temperature frames [K] and emissivity on a regular grid, streamed to the camera.

Every scene type lives here; :mod:`radiosim.io` keeps the readers that build them from files.
"""

from radiosim.scenes.analytic import MovingGaussianBand, StepEdge, UniformBlackbody
from radiosim.scenes.base import CroppedScene, Scene, SceneFrame
from radiosim.scenes.exr_sequence import ExrSequence
from radiosim.scenes.fea_nodes import FeaMesh, FeaNodes
from radiosim.scenes.framestack import FrameStack
from radiosim.scenes.segmented_chip import ChipParameters, SegmentedChip

__all__ = [
    "Scene",
    "SceneFrame",
    "CroppedScene",
    "FrameStack",
    "ExrSequence",
    "FeaNodes",
    "FeaMesh",
    "UniformBlackbody",
    "MovingGaussianBand",
    "StepEdge",
    "SegmentedChip",
    "ChipParameters",
]
