"""Plain-loop ports of Dollár's toolbox used as references by the metrics tests."""

import math

from tests.tolerances import EXACT

#: pytest.approx spelling of EXACT (float64 arithmetic on counts; no iterative algorithm).
APPROX = dict(rel=EXACT["rtol"], abs=EXACT["atol"])


def toolbox_lamr(xs, ys, ref):
    """Plain-loop port of dbEval: xs = fppi, ys = recall, curve by decreasing score.

    xs1=[-inf; xs]; ys1=[0; ys];
    for i=1:m, j=find(xs1<=ref(i)); ref(i)=ys1(j(end)); end
    miss=exp(mean(log(max(1e-10,1-ref))));
    """
    xs1 = [-math.inf] + list(xs)
    ys1 = [0.0] + list(ys)
    logs = []
    for r in ref:
        j = [i for i, x in enumerate(xs1) if x <= r]
        logs.append(math.log(max(1e-10, 1.0 - ys1[j[-1]])))
    return math.exp(sum(logs) / len(logs))
