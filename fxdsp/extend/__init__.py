"""``fxdsp extend``: from a measured log to a verified compensation (issues 14, 27).

diagnose the log -> plan a hardware remedy for every named cause that has one, the rest reported
uncompensated (:mod:`.plan`) -> calibrate the chain's compensation and write the extended config
in the user's design (:mod:`.configure`, :mod:`.design`) -> held-out error with and without each
remedy (:mod:`.evaluate`) -> golden vectors, Verilog headers, cocotb regression and hardware cost
(:mod:`.hardware`) -> Markdown + JSON + plots (:mod:`.report`).
"""
