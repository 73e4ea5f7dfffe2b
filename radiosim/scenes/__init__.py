"""Scenes: temperature frames [K] on a regular grid, streamed to the camera."""

from radiosim.scenes.analytic import MovingGaussianBand, StepEdge, UniformBlackbody
from radiosim.scenes.base import CroppedScene, Scene
from radiosim.scenes.segmented_chip import ChipParameters, SegmentedChip
from radiosim.scenes.framestack import FrameStack

__all__ = [
    "Scene",
    "CroppedScene",
    "FrameStack",
    "UniformBlackbody",
    "MovingGaussianBand",
    "StepEdge",
    "SegmentedChip",
    "ChipParameters",
]
