"""What the estimators return: models, fit records and statuses, and their files.

:mod:`.base` (sizes and names of everything with A_t, B_t), :mod:`.record`
(:class:`~ltvmodels.FitStatus`, :class:`~ltvmodels.FitRecord`),
:mod:`.regression` (:class:`~ltvmodels.RegressionModel`), :mod:`.statespace`
(:class:`~ltvmodels.LTVModel`), :mod:`.arx` (AR/ARX models), :mod:`.kalman`,
:mod:`.selection`, :mod:`.segmentation`, :mod:`.changepoints` (change points on the
data's axis), and the model file (:mod:`.archive`,
:mod:`.loading`).
"""

__all__: list[str] = []
