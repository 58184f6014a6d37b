"""Files: ParaView output (:mod:`.export`, VTU series and a PVD index via meshio), a
continuum member's shape for CAD (:mod:`.cad`, DXF, SVG and STL), results saved to one
``.npz`` and read back bit for bit (:mod:`.saved`), and sealed, verified optimization
checkpoints (:mod:`.checkpoint`)."""

from . import cad, checkpoint, export, saved

__all__ = ["cad", "checkpoint", "export", "saved"]
