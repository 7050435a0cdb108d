"""``make models``: every fabric law (``model.params.VARIANTS``) fitted as ``make fit`` fits, and judged by the runs
it was not fitted on.

``python -m pipeline.model_selection [--preset P] [--engine E] [--set K=V] [--across P[:E]|none ...]
[--laws L,...] [--out DIR]``. For each variant, the global fit (``calibration.global_fit``: the same definitions,
noise model and weights as ``make fit``; the dilatancy is not fitted, Phi is not scored) on

- every run of the default protocol: in-sample misfit, AIC and BIC, parameters with their 68 % intervals from the
  noise, and whether the variant's own reversal runs;
- ``angles`` (``splits.LeaveAnglesOut``): the reversal and 30, 60, 90 only, predicting 120, 150 and Fig. 7's turns
  at 0.1 and 0.2;
- ``without <theta>`` (``splits.LeaveOneAngleOut``): every angle but one, predicting that one (over all six);
- ``across``: every run of another data set, predicting this one's (and this one's predicting the other's).

A held-out run is never in the fit nor in the noise model that weighs it: the noise is measured on the training
runs and scales the held-out residuals. Per held-out run and component: the RMS error over the cycle in units of the
run's noise and per the DEM's steady value. Writes ``models.json``, ``models.md``, ``models.h5`` (the curves
``figures.models`` draws) and ``params-<variant>.json`` in ``results/<data set>/models/``. Modules: ``splits``,
``judge`` (the fits), ``scores`` (held-out errors, the z-test), ``curves`` (the figure's data), ``text``, ``inputs``.
"""
