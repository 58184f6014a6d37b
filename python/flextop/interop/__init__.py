"""Adapters to the optimization tools users already have: :mod:`flextop.interop.scipy`
(``scipy.optimize.minimize``) and :mod:`flextop.interop.openmdao` (an OpenMDAO component).
Each evaluates a :class:`flextop.optimizers.Problem` once per design and serves values and
gradients from that one evaluation."""
