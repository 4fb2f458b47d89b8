"""
The wear alarm rule: its defaults, the decision on one estimate or a batch, and the latch.

One rule for every user: the monitoring service (nodes, replay, demo) latches it with
:class:`AlarmLatch`, ``bench/bench_alarm.py`` evaluates it on whole simulated tests with
:meth:`AlarmPolicy.decide`.  Two rules are offered (``rule``):

* ``trend`` (the default): raise when the wear trend's posterior P(w >= threshold)
  (:attr:`robot_wear_monitor.estimation.trend.TrendEstimate.probability_above_threshold`)
  reaches ``probability``.  p = 0.15 was chosen with ``bench/bench_alarm.py`` (simulated
  accelerated wear tests of the paper's three scenario shapes, N = 1, 2, 4, 100 runs each):
  against the paper's single threshold on each estimate (w-hat >= 35) it has fewer or as many
  false alarms while the true w < 25 in every scenario and N (in total 23 against 85 runs; 13 %
  against 48 % in the worst case, scenario 2 with N = 1) and a smaller mean detection delay
  overall (0.20 against 0.25 experiments), but a larger one on the steep scenario 2 (0.18-0.33
  against 0.03-0.11), where the single threshold gains its speed from early alarms in the 25-35
  band (40-84 % of its runs).
* ``estimate``: the paper's rule, a threshold on each estimate, w-hat >= 35, optionally with
  accumulated evidence as well: a one-sided CUSUM of the Gaussian log-likelihood ratio between
  the threshold ``w1`` (35) and the healthy level ``w0`` (25), each estimate weighted by its own
  variance,

      llr_k = (w1 - w0) * (w-hat_k - (w0 + w1) / 2) / std_k^2,    S_k = max(0, S_(k-1) + llr_k)

  and the alarm is raised at the first estimate with ``w-hat_k >= w1`` and ``S_k >= h`` (h =
  ``evidence_to_raise``, node parameter ``alarm_evidence``).  h = 0 (default) is the paper's
  rule: a Monte Carlo of the N = 4 design over wear trends like the paper's Sec. V scenarios, T
  in 30..50 degC and the load uncertainty gives a false alarm while w < 25 in 0-4 % of the runs
  and an alarm within two experiments of w crossing 35 in 96-100 %; h = 2 gives a little fewer
  false alarms for a little later detection.

The latched alarm stays active until reset (maintenance), which also clears the evidence.  The
module also owns the defaults of the wear levels (w is the paper's dimensionless wear level, 0 =
new, 100 = failure) that the node parameters, the trend filter and the command line read.
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
from numpy.typing import ArrayLike, NDArray
from robot_wear_monitor.errors import InputError
from robot_wear_monitor.setting_fields import (check_settings, non_negative, open_fraction,
                                               positive, setting)

#: Alarm level of the wear w [-] (the paper's Sec. V): the alarm is about w >= this.
WEAR_THRESHOLD = 35.0
#: Wear level that must not raise an alarm [-] (w0 of the evidence test).
WEAR_HEALTHY = 25.0
#: Wear level from which the diagnostics warn [-].
WEAR_WARNING = 28.0
#: The rules: ``trend`` (posterior probability of the trend) and ``estimate`` (the paper's).
ALARM_RULES = ('trend', 'estimate')
#: The default rule.
DEFAULT_ALARM_RULE = 'trend'
#: Posterior P(w >= threshold) that raises the ``trend`` alarm [-], chosen by
#: ``bench/bench_alarm.py``.
DEFAULT_ALARM_PROBABILITY = 0.15
#: CUSUM evidence h the ``estimate`` rule also needs [-]; 0: one estimate >= threshold.
DEFAULT_ALARM_EVIDENCE = 0.0


def alarm_rule_problem(value: str) -> Optional[str]:
    """Return what is wrong with an alarm rule's name (one of :data:`ALARM_RULES`), or None."""
    return None if value in ALARM_RULES else 'must be ' + ' or '.join(
        f'"{rule}"' for rule in ALARM_RULES)


@dataclass(frozen=True)
class AlarmPolicy:
    """
    The alarm rule and its parameters.

    :ivar threshold: alarm level w1 of the wear [-].
    :ivar healthy: healthy level w0 [-], below ``threshold``.
    :ivar evidence_to_raise: CUSUM evidence h the ``estimate`` rule also needs (>= 0) [-].
    :ivar rule: one of :data:`ALARM_RULES`.
    :ivar probability: posterior P(w >= threshold) that raises the ``trend`` alarm, 0 < p < 1.

    """

    threshold: float = setting(
        WEAR_THRESHOLD, unit='-', check=positive,
        description='alarm level of the wear w: the alarm is raised by an estimate >= it')
    healthy: float = setting(
        WEAR_HEALTHY, unit='-', check=non_negative,
        description='wear level that must not raise an alarm; the evidence test weighs each '
                    'estimate between this level and the threshold')
    evidence_to_raise: float = setting(
        DEFAULT_ALARM_EVIDENCE, unit='-', check=non_negative,
        description=('CUSUM log-likelihood ratio (worn vs healthy) an estimate >= the '
                     "threshold also needs to raise the alarm; 0: the paper's rule, one "
                     'estimate >= the threshold is enough'))
    rule: str = setting(
        DEFAULT_ALARM_RULE, check=alarm_rule_problem,
        description='what raises the wear alarm: "trend" (the filtered trend\'s P(w >= '
                    'threshold) reaches the alarm probability) or "estimate" (the paper\'s '
                    'rule: one estimate >= the threshold, with the alarm evidence)')
    probability: float = setting(
        DEFAULT_ALARM_PROBABILITY, unit='-', check=open_fraction,
        description='with the rule "trend": the posterior probability of w >= the threshold '
                    'that raises the alarm')

    def __post_init__(self) -> None:
        """Reject a policy whose healthy level is not below the threshold, or a bad rule."""
        check_settings(self, prefix='alarm policy: ')
        if not (self.healthy < self.threshold and self.evidence_to_raise >= 0):
            raise InputError(f'alarm policy: need healthy < threshold and evidence >= 0, got '
                             f'healthy={self.healthy}, threshold={self.threshold}, '
                             f'evidence={self.evidence_to_raise}')
        if self.rule not in ALARM_RULES or not 0.0 < self.probability < 1.0:
            raise InputError(f'alarm policy: rule must be one of {", ".join(ALARM_RULES)} and '
                             f'0 < probability < 1, got {self.rule!r}, {self.probability}')

    def log_likelihood_ratio(self, *, wear: float, wear_std: float) -> float:
        """Return llr of one estimate, 0 when its standard deviation is unknown or infinite."""
        if not (math.isfinite(wear) and math.isfinite(wear_std) and wear_std > 0):
            return 0.0
        midpoint = 0.5 * (self.threshold + self.healthy)
        return (self.threshold - self.healthy) * (wear - midpoint) / wear_std ** 2

    def decide(self, *, wear: ArrayLike = math.nan,
               probability_above_threshold: ArrayLike = math.nan,
               evidence: Optional[ArrayLike] = None) -> NDArray[np.bool_]:
        """
        Return whether the rule calls for the alarm, elementwise (any matching shapes).

        Rule ``trend``: ``probability_above_threshold >= probability``.  Rule ``estimate``:
        ``wear >= threshold`` and ``evidence >= evidence_to_raise``; ``evidence`` None (no
        CUSUM kept, e.g. a benchmark of single estimates) is allowed only with
        ``evidence_to_raise == 0``, where it never decides.  NaN never raises.

        :param wear: w-hat of each estimate [-].
        :param probability_above_threshold: the trend's posterior P(w >= threshold) [-].
        :param evidence: CUSUM evidence after each estimate [-].

        :raises InputError: ``evidence`` None with ``evidence_to_raise > 0``.

        """
        if self.rule == 'trend':
            return np.asarray(probability_above_threshold, dtype=float) >= self.probability
        above = np.asarray(wear, dtype=float) >= self.threshold
        if evidence is None:
            if self.evidence_to_raise > 0:
                raise InputError('alarm policy: the estimate rule with evidence_to_raise > 0 '
                                 'needs the evidence')
            return above
        return above & (np.asarray(evidence, dtype=float) >= self.evidence_to_raise)


class AlarmLatch:
    """A latched wear alarm: :meth:`AlarmPolicy.decide` fed by the CUSUM of the estimates."""

    def __init__(self, policy: AlarmPolicy, *, active: bool = False,
                 evidence: float = 0.0) -> None:
        """Start in the given (restored) state."""
        self.policy = policy
        self.active = bool(active)
        self.evidence = max(0.0, float(evidence))

    def update(self, *, wear: float, wear_std: float,
               probability_above_threshold: float = math.nan) -> bool:
        """
        Add one estimate; return True when this estimate raises the alarm.

        The evidence is updated by every estimate, also while the alarm is active; an active
        alarm is not raised again.
        """
        llr = self.policy.log_likelihood_ratio(wear=wear, wear_std=wear_std)
        self.evidence = max(0.0, self.evidence + llr)
        if self.active:
            return False
        if self.policy.decide(wear=wear, evidence=self.evidence,
                              probability_above_threshold=probability_above_threshold):
            self.active = True
            return True
        return False

    def reset(self) -> bool:
        """Clear the alarm and the evidence; return whether it was active."""
        was_active = self.active
        self.active = False
        self.evidence = 0.0
        return was_active
