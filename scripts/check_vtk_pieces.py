"""Reads a split run's VTK pieces with VTK's own readers and checks them.

Usage: python scripts/check_vtk_pieces.py RUN_DIR  (needs `pip install vtk`)

For every frame of RUN_DIR/particles.pvd: each piece (one per MPI rank,
`part=` in the collection) reads as PolyData with a vertex per point, and
the pieces together hold the particles of the frame's merged PLY cache,
each exactly once (compared as bits).
"""

import sys
import xml.etree.ElementTree as ElementTree

import numpy as np
import vtk
from vtk.util.numpy_support import vtk_to_numpy


def points_of(reader, path):
    """The points of the file at `path` read by `reader`, as (n, 3) bits."""
    reader.SetFileName(path)
    reader.Update()
    data = reader.GetOutput()
    if data.GetNumberOfPoints() == 0:
        return data, np.zeros((0, 3), np.uint32)
    points = vtk_to_numpy(data.GetPoints().GetData()).astype(np.float32)
    return data, points.view(np.uint32).reshape(-1, 3)


def main(run):
    root = ElementTree.parse(f"{run}/particles.pvd").getroot()
    frames = {}
    for data_set in root.iter("DataSet"):
        frames.setdefault(data_set.get("timestep"), []).append(
            (int(data_set.get("part")), data_set.get("file"))
        )
    for index, (time, pieces) in enumerate(frames.items()):
        together = []
        for part, file in pieces:
            data, points = points_of(vtk.vtkXMLPolyDataReader(), f"{run}/{file}")
            assert data.GetNumberOfVerts() == len(points), file
            together.append(points)
        together = np.concatenate(together)
        _, merged = points_of(vtk.vtkPLYReader(), f"{run}/ply/frame_{index:05d}.ply")
        same = sorted(map(tuple, together.tolist())) == sorted(map(tuple, merged.tolist()))
        print(
            f"frame {index} (t = {time}): {len(pieces)} pieces, {len(together)} points, "
            f"PLY {len(merged)}, each particle once: {same}"
        )
        if not same:
            sys.exit(1)


if __name__ == "__main__":
    main(sys.argv[1])
