"""Calibration: the emulator's settings fitted to a real robot's own runs, written as a robot profile.

from autonomy.calibration import Probe, fit, from_trace
recording = Probe(client, wall_mm=1000).run()     # drives the robot: a short, safe routine
found = fit(recording)                            # least squares: found.params, found.values
recording = from_trace("run.jsonl")               # or an earlier run's trace, without driving
"""

from autonomy.calibration.fit import Fit, FitError, Fitted, fit, predict
from autonomy.calibration.probe import Probe, ProbeRefused, ProbeStopped
from autonomy.calibration.recording import Recording, Sample, Sent, from_trace

__all__ = [
    "Fit",
    "FitError",
    "Fitted",
    "Probe",
    "ProbeRefused",
    "ProbeStopped",
    "Recording",
    "Sample",
    "Sent",
    "fit",
    "from_trace",
    "predict",
]
