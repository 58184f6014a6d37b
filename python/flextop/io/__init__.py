"""Files: ParaView output (:mod:`.export`, VTU series and a PVD index via meshio), results
saved to one ``.npz`` and read back bit for bit (:mod:`.saved`), and sealed, verified
optimization checkpoints (:mod:`.checkpoint`)."""

from . import checkpoint, export, saved

__all__ = ["checkpoint", "export", "saved"]
