"""The library's own commands, ``viewadapt detect`` and ``viewadapt calibrate``: files in, files
out, through :mod:`viewadapt.io`; registered with the command line (:mod:`viewadapt.cli`)
as entry points."""
