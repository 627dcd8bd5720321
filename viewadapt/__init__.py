"""viewadapt: viewpoint adaptation for rigid object detectors (Wang et al. 2017)."""
__version__ = "0.1.0"
