"""Read a dolfinx XDMF time series back (XML + HDF5) the way a reader like ParaView's does.

meshio has no 'PolyLine' (1D) topology, so 1D output is read here with ElementTree and h5py.
"""

import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np


def read_xdmf(path: Path) -> tuple[np.ndarray, dict[str, list[tuple[float, np.ndarray]]]]:
    """Return (geometry, {field: [(t, values), ...]}) of a dolfinx XDMF file."""
    root = ET.parse(path).getroot()
    domain = root.find("Domain")
    assert domain is not None

    def h5(item: ET.Element) -> np.ndarray:
        fname, dset = item.text.strip().split(":")
        with h5py.File(path.parent / fname, "r") as f:
            return np.array(f[dset])

    geometry = h5(domain.find("Grid/Geometry/DataItem"))
    fields: dict[str, list[tuple[float, np.ndarray]]] = {}
    for coll in domain.findall("Grid[@GridType='Collection']"):
        for grid in coll.findall("Grid"):
            t = float(grid.find("Time").get("Value"))
            attr = grid.find("Attribute")
            fields.setdefault(attr.get("Name"), []).append((t, h5(attr.find("DataItem"))))
    return geometry, fields
