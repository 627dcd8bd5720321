"""One-off: sweep_decomposition under rotated negatives with the SVM at C = 0.001."""
import sys
from dataclasses import replace
from pathlib import Path
import benchmark.studies.sweep_decomposition as sd
from benchmark.recipes import get_recipe
import benchmark.recipes as R
rec = replace(get_recipe("rotated"), name="rotated_c0.001", svm_c=0.001,
              summary="rotated's negatives, the SVM at C = 0.001")
orig = R.get_recipe
R.get_recipe = lambda name: rec if name == "rotated_c0.001" else orig(name)
R.RECIPES = dict(R.RECIPES, **{"rotated_c0.001": rec})
sys.exit(sd.main(["--data", "/tmp/exp/dsfx", "--out", "/tmp/s11/decomp_fx0_rotreg",
                  "--cache", "/tmp/s11/sweep_fx0/cache", "--recipe", "rotated_c0.001"]))
