"""`fxdsp diagnose`: explain where a measured log disagrees with the baseline model.

See shared/spec/measured-data.md for the contract (log format, causes, report).
"""

from fxdsp.diagnose.api import diagnose_file, diagnose_log, series_from_log
from fxdsp.diagnose.logio import Log, parse_mapping, read_log

__all__ = ["diagnose_file", "diagnose_log", "series_from_log", "Log", "parse_mapping", "read_log"]
