"""
Closing the loop: find what the friction model misses, name it, and put it into the model.

Modules, by what a newcomer looks for:

* :mod:`.data`: reading level tables (CSV), raw runs and bags into an ``AuditTable``;
* :mod:`.fitting`: the identification core shared with ``identify`` (variable projection);
* :mod:`.cross_validation`: folds by experiment and the held-out error;
* :mod:`.candidates`: every column a suspect, and the bases it is tested with;
* :mod:`.significance`: the nested F-tests, the periodic scan, Benjamini-Hochberg, confounding;
* :mod:`.shapes`: naming the shape of an effect (the term that is added);
* :mod:`.noise`: the noise floor;
* :mod:`.run`: the audit loop (:func:`~robot_wear_monitor.audit.run.run_audit`);
* :mod:`.result`: the result and its JSON/text report; :mod:`.figures`: the figures;
* :mod:`.export`: the parameter set with the added terms (``audit --out-params``);
* :mod:`.estimates`: the T and w estimates before and after the extension;
* :mod:`.identification`: ``identify`` (a parameter set from a robot's own levels).
"""
