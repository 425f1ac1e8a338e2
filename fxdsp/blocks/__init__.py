"""The blocks of the compensation chain: each a bit-exact fixed model with a float reference."""
