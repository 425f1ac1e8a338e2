"""Independent test material for ``fxdsp diagnose``: logs generated from the contract alone."""
