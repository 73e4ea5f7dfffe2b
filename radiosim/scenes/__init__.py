"""Scenes: temperature frames [K] on a regular grid, streamed to the camera."""

from radiosim.scenes.analytic import MovingGaussianBand, UniformBlackbody
from radiosim.scenes.base import Scene
from radiosim.scenes.framestack import FrameStack

__all__ = ["Scene", "FrameStack", "UniformBlackbody", "MovingGaussianBand"]
