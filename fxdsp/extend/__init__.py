"""``fxdsp extend``: from a measured log to a verified compensation (issue 14).

diagnose the log -> plan a hardware remedy for every named cause (:mod:`.plan`) -> calibrate the
chain's compensation and write the extended config (:mod:`.configure`) -> held-out error with and
without each remedy (:mod:`.evaluate`) -> golden vectors, Verilog headers, cocotb regression and
hardware cost (:mod:`.hardware`) -> Markdown + JSON + plots (:mod:`.report`).
"""
