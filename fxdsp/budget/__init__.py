"""Float vs fixed error budget, attribution, theory check and word-length exploration (fxdsp budget)."""
