"""
Fleet views on top of the monitoring: re-analysis of many recordings and the ranked fleet.

``batch``: replay many bags (a process pool on this machine or an existing Dask cluster), one
task per bag, the bags of one robot in time order; ``ranking``: one row per robot and joint
from the history, worst first.
"""
