"""What a real InSb camera reads on the segmented chip (the Python twin of real_camera.toml).

Run: python examples/real_camera.py
"""

import numpy as np

import radiosim as rs
from radiosim.scenes import SegmentedChip
from radiosim.paper import column_summary
from radiosim.study import summarise


def main(rng=0):
    steel = "emissivity_steel_clean"  # Hagen-Rubens clean steel, about 0.18 in 3-5 µm
    scene = SegmentedChip(dt=0.2e-6, emissivity={"chip": steel, "workpiece": steel,
                                                 "tool": 0.4, "air": 1.0})
    camera = rs.Camera.preset("nist-ir").replace(name="nist", assumed_emissivity=0.2)
    # One seed per measurement, spawned in order, as a study spawns them (the same bits in
    # one process and on any Dask cluster).
    seeds = np.random.SeedSequence(rng).spawn(2)
    rows = []
    for t_int, seed in zip((1e-6, 10e-6), seeds):
        m = camera.measure(scene, t_int, rng=np.random.default_rng(seed))
        rows.append({"integration_time_us": t_int * 1e6, **summarise(m), **column_summary(m, scene)})
    return rows


if __name__ == "__main__":
    for row in main():
        print(f"{row['integration_time_us']:g} µs: peak {row['peak_C']:.1f} °C "
              f"(scene {row['peak_scene_C']:.1f} °C), Column I {row['column_I_C']:.1f} °C "
              f"(scene {row['column_I_scene_C']:.1f} °C), saturated "
              f"{100 * row['saturated_fraction']:.1f} %")
