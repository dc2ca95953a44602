"""Element formulations, one module per kind of element behind one protocol
(:class:`~crane_fem.formulations.protocol.Formulation`): 3D solid P1 tetrahedra, the axial
bar, Timoshenko beams."""

from crane_fem.formulations.bar import AxialBar
from crane_fem.formulations.beam import SECTION_FORCES, BeamStress, TimoshenkoBeam, local_axes
from crane_fem.formulations.protocol import (
    CellFields,
    Forms,
    Formulation,
    SectionFields,
    cell_function,
    coefficient,
)
from crane_fem.formulations.solid import SolidP1, SolidVonMises

__all__ = [
    "FORMULATIONS",
    "SECTION_FORCES",
    "AxialBar",
    "BeamStress",
    "CellFields",
    "Forms",
    "Formulation",
    "SectionFields",
    "SolidP1",
    "SolidVonMises",
    "TimoshenkoBeam",
    "cell_function",
    "coefficient",
    "local_axes",
]

#: The formulations by name.
FORMULATIONS: dict[str, Formulation] = {
    "solid": SolidP1(),
    "bar": AxialBar(),
    "beam": TimoshenkoBeam(),
}
