"""
Batches of serialised /joint_states messages, segmented as the replay segments a bag.

The friction_experiment_node drains its /joint_states queue every ``drain_period_s``
(:mod:`robot_wear_monitor.monitoring.drain_config`) and hands the batch here as the middleware
holds it: the CDR bytes of each message and its reception time.  :class:`JointStateBatches`
decodes a batch with the replay's vectorised JointState decoder
(:class:`~robot_wear_monitor.recordings.bags.cdr.MultiDecoder`, one gather for the whole
batch) and feeds each monitored joint's samples to its
:class:`~robot_wear_monitor.monitoring.experiment_service.FrictionExperimentService` with
``add_recording``, the chunked segmenter the replay feeds a bag's chunks to.  The segmenter
gives the same levels for any cut of a recording into chunks, so the node publishes the
replay's friction levels, bit for bit (tested), however its batches fall.

The messages the decoder refuses for a joint (no such joint, a missing array, arrays shorter
than the names, bytes that are no JointState: ``malformed``) are counted on the joint's service
under the reasons the per-message path counts them, and as messages of its stream.  A message
with a zero header stamp takes its reception time, as in the per-message path.
"""

from __future__ import annotations

from collections import Counter
from typing import Any, Optional, Sequence

import numpy as np
from robot_wear_monitor.experiment.levels import FrictionExperiment
from robot_wear_monitor.monitoring.experiment_service import FrictionExperimentService
from robot_wear_monitor.monitoring.joints import JointExperiments
from robot_wear_monitor.recordings.bags.cdr import MultiDecoder

Completed = list[tuple[FrictionExperimentService, FrictionExperiment]]


class JointStateBatches:
    """
    Decode and segment batches of serialised JointState messages (see the module docstring).

    :ivar experiments: the monitored joints' services (the node's).
    :ivar messages: the messages added so far.

    """

    def __init__(self, experiments: JointExperiments) -> None:
        """Decode for the monitored joints of ``experiments`` (every joint seen under [all])."""
        self.experiments = experiments
        self.decoder = MultiDecoder(experiments.selection)
        self.messages = 0
        self._counted: dict[str, Counter] = {}  # the reader's rejections already counted

    def add(self, raws: Sequence[bytes], receive_ns: Any) -> Completed:
        """
        Add one batch; return the experiments it completes, in the order of their ends.

        ``raws``: the CDR bytes of each message, in arrival order; ``receive_ns``: their
        reception times [ns] on the node's clock, shape (len(raws),) (used for zero stamps).
        """
        if not len(raws):
            return []
        before = (self.decoder.messages, self.decoder.malformed)
        chunk = self.decoder.decode(list(raws), np.asarray(receive_ns, dtype=np.int64))
        self.messages += len(raws)
        done: Completed = []
        for joint, samples in chunk.items():
            service = self._service(joint, before)
            if service is None or not len(samples):
                continue
            done += [(service, experiment) for experiment in service.add_recording(
                time_s=samples.time_s, position_rad=samples.position_rad,
                velocity_rad_s=samples.velocity_rad_s, effort=samples.effort)]
        self._count_rejections()
        return sorted(done, key=lambda pair: pair[1].end_time_s)

    def _service(self, joint: str, before: tuple[int, int]
                 ) -> Optional[FrictionExperimentService]:
        """
        Return the service of a decoded joint (built when first seen under [all]), else None.

        A joint first seen in this batch starts its count of the reader's rejections here: the
        messages before this batch had no such joint, and are not its stream.
        """
        service = self.experiments.seen(joint)
        if service is not None and joint not in self._counted:
            parsed_before = before[0] - before[1]
            self._counted[joint] = Counter({'joint_missing': parsed_before,
                                            'malformed': before[1]})
        return service

    def _count_rejections(self) -> None:
        """Count the reader's new rejections of each monitored joint on its service."""
        for joint, counts in self.decoder.rejections().items():
            counted = self._counted.get(joint)
            if counted is None:
                continue
            new = counts - counted
            if new:
                self.experiments.services[joint].add_reader_rejections(new)
                counted.update(new)
