"""Numerics on plain arrays: the regression problem and the solvers behind every estimator.

Nothing here validates user input or builds result objects (see
ARCHITECTURE.md): :mod:`.problem` (the regression y_t = Θ_t φ_t + e_t and the
difference operators), the compiled kernels (:mod:`.blockkernels`,
:mod:`.conekernels`, :mod:`.dense`, :mod:`.simulation`), the squared norm
(:mod:`.banded`, :mod:`.squared`, :mod:`.priorterms`, :mod:`.covariance`), the
Kalman recursions (:mod:`.kalman`), the sparse norms (:mod:`.sparse` choosing
among :mod:`.ipm`, :mod:`.polish` and :mod:`.admm`, with :mod:`.sparse_common`),
segmentation (:mod:`.segmentation`), AR/ARX regressors (:mod:`.lags`) and
identifiability (:mod:`.identifiability`).
"""

__all__: list[str] = []
