"""Float vs fixed error budget, attribution, theory check and word-length exploration (fxdsp budget)."""

# the share of the target an optimised design keeps in hand (its error is held to (1 - margin) x
# target): budget --optimise and sweep wordlength (here, where their parsers read it without loading
# the search)
DEFAULT_MARGIN = 0.02
