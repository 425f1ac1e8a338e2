"""Sweeps that outgrow one machine: the engine (:mod:`.engine`: tasks, seeds, serial or Dask
execution, retries, the journal that makes a sweep resumable) and one module per sweep kind
(:mod:`.montecarlo`, :mod:`.wordlength`, :mod:`.hidden`, :mod:`.rtl`); ``fxdsp sweep`` (:mod:`fxdsp.commands.sweep`)
runs them."""
