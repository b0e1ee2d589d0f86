"""Matplotlib figures of identified LTV models.

matplotlib is imported inside the functions, so importing this package does
not load it. New figures are created as :class:`matplotlib.figure.Figure`
objects directly (not through :mod:`matplotlib.pyplot`), so nothing here
needs a display or a GUI backend: save them with ``fig.savefig(path)``; in
Jupyter a returned figure displays itself. To draw into a pyplot figure or
axes, pass it as ``fig`` / ``ax``.

The functions receive what they draw as data: any model object with the
attributes they use (:class:`ltvmodels.LTVModel` has them all), arrays, or a
:class:`~ltvmodels.LambdaSelection`. They never fit anything.
"""

from .breaktest import plot_break_test
from .coefficients import (
    plot_activation,
    plot_coefficients,
    plot_eigenvalues,
    plot_model,
    plot_poles,
)
from .segments import plot_breaks, plot_criteria
from .selection import plot_lambda_selection
from .signals import (
    plot_forecast,
    plot_root_spectrogram,
    plot_simulation,
    plot_spectrogram,
    plot_states,
)

__all__ = [
    "plot_coefficients",
    "plot_activation",
    "plot_eigenvalues",
    "plot_poles",
    "plot_root_spectrogram",
    "plot_spectrogram",
    "plot_simulation",
    "plot_states",
    "plot_forecast",
    "plot_lambda_selection",
    "plot_model",
    "plot_breaks",
    "plot_criteria",
    "plot_break_test",
]
