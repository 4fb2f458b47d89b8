"""
Segmentation of one joint's stream into constant-speed friction levels, eq. (3) of the paper.

The friction experiment moves one joint back and forth around a position phi_bar at a constant
speed; every forward/backward pair of constant-speed passes at one speed level over one
position window gives a friction level tau_f = (tau+ - tau-) / 2, in which gravity cancels.
The work is split along its seams, and this module hands the names on (import from here):

* :mod:`~robot_wear_monitor.experiment.segmentation_settings`: :class:`SegmenterConfig` and
  the one owner of its defaults (:data:`STREAM_SETTINGS` for bags and streams,
  :data:`RAW_RUN_SETTINGS` for measured raw runs);
* :mod:`~robot_wear_monitor.experiment.passes`: the pass finder and pairer, streaming
  (:class:`StreamingSegmenter`), chunked (:class:`ChunkSegmenter`) and batch
  (:func:`segment_batch`), which give identical levels (the pipeline is described there);
* :mod:`~robot_wear_monitor.experiment.assembly`: levels into experiments
  (:class:`ExperimentAssembler`, :func:`merge_levels`, :class:`SpeedTally`).
"""

from robot_wear_monitor.experiment.assembly import (ExperimentAssembler, merge_levels,
                                                    SpeedTally)
from robot_wear_monitor.experiment.passes import (ChunkSegmenter, one_way_passes,
                                                  pair_passes, Pass, PASS_REASONS, pick_joint,
                                                  same_speed, SAMPLE_LIMITS, SAMPLE_REASONS,
                                                  SATURATED_FRACTION, segment_batch,
                                                  SegmentationResult, StreamingSegmenter)
from robot_wear_monitor.experiment.segmentation_settings import (raw_run_segmenter_config,
                                                                 RAW_RUN_SETTINGS,
                                                                 SegmenterConfig,
                                                                 stream_segmenter_config,
                                                                 STREAM_SETTINGS)

__all__ = ['ChunkSegmenter', 'ExperimentAssembler', 'merge_levels', 'one_way_passes',
           'pair_passes', 'Pass', 'PASS_REASONS', 'pick_joint', 'RAW_RUN_SETTINGS',
           'raw_run_segmenter_config', 'same_speed', 'SAMPLE_LIMITS', 'SAMPLE_REASONS',
           'SATURATED_FRACTION', 'segment_batch', 'SegmentationResult', 'SegmenterConfig',
           'SpeedTally', 'STREAM_SETTINGS', 'stream_segmenter_config', 'StreamingSegmenter']
