"""
The built-in segmented-chip scene: a kinematic thermal model of orthogonal cutting.

The paper's FEA movie (AdvantEdge, AISI 1045, 250 m/min, 0.3 mm feed) is not public, so radiosim
ships a closed-form, physically motivated temperature field of orthogonal cutting with a
segmented chip, periodic in time with the segmentation period, that can be evaluated at any time
on any grid. Its specification is ``docs/scene.md`` (model, parameters and calibration); the
terms, superposed on the initial temperature T₀, are:

1.  the primary shear zone, a smooth step T_b(ξ) across the shear plane L0;
2.  the forming shear band on L0, growing through the cycle and narrowing as it intensifies;
3.  released bands carried up the rake face with the chip (stick–slip) and diffusing;
4.  the secondary (friction) zone along the rake face: Jaeger's high-Péclet moving band source,
    with a periodic modulation that travels with the chip;
5.  the tool, heated through the rake face (erfc conduction plus a damped periodic part);
6.  the workpiece, with the primary-zone step and a thin heated layer on the machined surface;
7.  regions (air, workpiece, chip with a saw-tooth free surface, tool), returned as a map so
    each region can carry its own emissivity.

Everything that does not move (geometry, the primary zone, the secondary zone's mean and the
two static fields of its travelling modulation, the tool, the workpiece) is computed once per
grid; a frame evaluates only the moving terms, on the samples they can reach. It does so with a
compiled kernel (numba, :func:`~.kernel.moving_terms_kernel`: one row-parallel pass writing the
frame, compiled on first use and cached on disk); the numpy implementation it replaces is kept
as its reference (:func:`~.reference.evaluate_reference`, the numpy engine's:
``set_engine("numpy")``), and the two agree to rounding; both are registered with the engines
(:mod:`radiosim.kernels.engines`) by :mod:`.scene`.

Modules, one concept each:

-   :mod:`.parameters`: :class:`ChipParameters`, SI units, TOML keys, derived quantities;
-   :mod:`.profiles`: the two smooth steps, a Gaussian's reach, Jaeger's band source;
-   :mod:`.geometry`: a grid's static fields and regions, and each region's index sets;
-   :mod:`.reference`: the moving terms in numpy (the oracle) and the time functions;
-   :mod:`.kernel`: the moving terms compiled (numba), driven by one named bundle of constants;
-   :mod:`.compiled`: the kernel's run layout per region, and its launch;
-   :mod:`.scene`: :class:`SegmentedChip`, the scene.

Coordinates: lab frame x to the right, y up, origin at the bottom-left corner of the field of
view; array row 0 is the top of the field (y = height), as in an image.

References
----------
-   Whitenton, E. P., Heigel, J. C. & Ivester, R. W. (2009). ASME MSEC2009-84319.
-   Jaeger, J. C. (1942). Moving sources of heat and the temperature at sliding contacts.
    Proc. R. Soc. N.S.W. 76, 203–224 (the high-Péclet band source; :mod:`.profiles`).
-   Merchant, M. E. (1945) and Lee & Shaffer (1951) for the shear-angle relation
    tan φ = r cos α / (1 − r sin α) (:mod:`.parameters`).
"""

from radiosim.scenes.segmented_chip.geometry import COLUMNS, REGIONS
from radiosim.scenes.segmented_chip.parameters import ChipParameters
from radiosim.scenes.segmented_chip.profiles import hermite_step, jaeger_band_source, tanh_step
from radiosim.scenes.segmented_chip.scene import SegmentedChip

__all__ = ["ChipParameters", "SegmentedChip", "REGIONS", "COLUMNS", "jaeger_band_source",
           "tanh_step", "hermite_step"]

