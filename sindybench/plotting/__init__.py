"""Figures for notebooks and reports: simulations, hysteresis loops, hidden states, coefficients, searches.

Every function draws on the matplotlib ``Axes`` given as ``ax=`` (so figures
can be composed), or on a new pyplot figure, and returns the axes it drew on.
matplotlib is imported inside the functions, so ``import sindybench`` stays
light. Models are given either fitted (anything with ``predict(X, y_init=...)``:
the open-loop simulation is computed here) or as arrays of simulated outputs.
``sindybench run`` draws its report figures with these functions.

The figures below come from one example: a forced oscillator whose velocity is
not measured, ``y'' = -4 y - 0.5 y' - 2 y^3 + 2 u``, fitted by plain SINDy on
``y`` alone and by :class:`~sindybench.HiddenStateSINDy` with the velocity as
a hidden state.

.. plot::
   :context: reset

   import numpy as np
   from sindybench import STLS, HiddenStateSINDy, SINDy
   from sindybench.hidden import DerivativeHiddenState
   from sindybench.libraries import PolynomialLibrary
   from sindybench.plotting import plot_simulation
   from sindybench.simulate import simulate

   def oscillator(x, u):
       return np.array([x[1], -4 * x[0] - 0.5 * x[1] - 2 * x[0] ** 3 + 2 * u[0]])

   dt = 0.01
   t = np.arange(3000) * dt
   u = (np.sin(t) + np.sin(2.3 * t))[:, None]
   y = simulate(oscillator, [0.0, 0.0], u, dt=dt, n_substeps=4)[:, :1]  # the position only
   library = PolynomialLibrary(degree=3)
   plain = SINDy(library=library, optimizer=STLS(threshold=0.05), dt=dt).fit(u, y)
   hidden = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library,
                             optimizer=STLS(threshold=0.05), dt=dt).fit(u, y)
   models = {"SINDy on y": plain, "hidden velocity": hidden}
   plot_simulation(u, y, models, n_init=20, dt=dt)

Loops of the output against the input (:func:`plot_hysteresis`), and against
the hidden velocity as the model simulates it:

.. plot::
   :context: close-figs

   import matplotlib.pyplot as plt
   from sindybench.plotting import plot_hysteresis

   last = slice(-400, None)  # the last four seconds
   fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
   plot_hysteresis(u[last], y[last], models, n_init=20, ax=left)
   plot_hysteresis(u[last], y[last], {"hidden velocity": hidden}, n_init=20, hidden="y0'", ax=right)

The hidden state as reconstructed from the training data (:func:`plot_hidden_states`):

.. plot::
   :context: close-figs

   from sindybench.plotting import plot_hidden_states

   plot_hidden_states(hidden)

The coefficients of both models (:func:`plot_coefficients`):

.. plot::
   :context: close-figs

   from sindybench.plotting import plot_coefficients

   plot_coefficients(models)

An inner search of the threshold (:func:`plot_search_history`; the study
returned by :func:`sindybench.model_selection.tune` is drawn the same way):

.. plot::
   :context: close-figs

   from sindybench.plotting import plot_search_history

   searched = HiddenStateSINDy(hidden=DerivativeHiddenState(order=2), library=library, optimizer=STLS(),
                               search_params={"optimizer__threshold": (1e-3, 10.0, True)},
                               n_trials=20, random_state=0, dt=dt).fit(u, y)
   plot_search_history(searched)
"""

from ._band import plot_prediction_band
from ._coefficients import coefficient_table, plot_coefficients
from ._common import MAX_POINTS
from ._error import envelope, error_spectrum, plot_error_spectrum, plot_output_error, zoom_window
from ._residuals import plot_residual_analysis
from ._search import plot_pareto_front, plot_search_history
from ._simulation import plot_hidden_states, plot_hysteresis, plot_simulation

__all__ = [
    "MAX_POINTS",
    "coefficient_table",
    "envelope",
    "error_spectrum",
    "plot_coefficients",
    "plot_error_spectrum",
    "plot_hidden_states",
    "plot_hysteresis",
    "plot_output_error",
    "plot_pareto_front",
    "plot_prediction_band",
    "plot_residual_analysis",
    "plot_search_history",
    "plot_simulation",
    "zoom_window",
]
