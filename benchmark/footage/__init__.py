"""``viewadapt bench footage``: every full-frame method on a user's calibrated, annotated clip.

:mod:`benchmark.footage.run` reads the clip (frames, calibration, ground truth, ignore
regions: :mod:`viewadapt.io`) and runs the methods of :mod:`benchmark.frames.spec` on every
frame, lens distortion handled as ``viewadapt detect`` handles it;
:mod:`benchmark.footage.report` evaluates them (Caltech protocol, block-bootstrap
intervals, paired differences) and writes the table and figure;
:mod:`benchmark.footage.command` is the command line.
"""
