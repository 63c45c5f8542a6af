"""Pure numerics shared by calibration, evaluation and the tests (numpy/scipy only, no Drake).

``decay``: damped-sinusoid free-decay fits with confidence intervals and the log decrement;
``metrics``: RMSE and the Point Mean Error of paper eq. 12.
"""

from sphere_env.analysis.decay import DecayFit, damped_sinusoid, fit_free_decay, log_decrement
from sphere_env.analysis.metrics import pme_percent, rmse

__all__ = ["DecayFit", "damped_sinusoid", "fit_free_decay", "log_decrement", "pme_percent", "rmse"]
