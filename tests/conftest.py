"""Shared test helpers."""


def frames_study(times_us, pixel_pitch_um: float, name: str = "small", camera: str = "lin",
                 sweep: str = "t") -> str:
    """A study TOML on ``frames.npy`` (1 µs frames of 1 µm samples, kelvin) beside it: one
    linear-ideal camera, one integration-time sweep."""
    times = ", ".join(f"{t:g}" for t in times_us)
    return f"""name = "{name}"
[scene]
type = "frames"
path = "frames.npy"
dt_us = 1.0
dx_um = 1.0
units = "K"
[cameras.{camera}]
preset = "linear-ideal"
pixel_pitch_um = {float(pixel_pitch_um)!r}
[[sweeps]]
name = "{sweep}"
cameras = ["{camera}"]
integration_time_us = [{times}]
"""
