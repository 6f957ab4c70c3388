"""The `candidates` encoder: DQN's policy over candidate views (`agent.algorithm: dqn`).

Its network, `CandidatePolicy`, stays in `vprobot.agents.candidate_q` beside the DQN it serves:
a saved DQN model names its policy class by that module, so the runs and bundled agents saved
so far load only from there.
"""

from vprobot.agents.candidate_q import CandidatePolicy
from vprobot.agents.encoders import ENCODERS, Encoder, NoSettings

CANDIDATES = ENCODERS.register("candidates", Encoder(
    CandidatePolicy,
    settings=NoSettings,
    # The head of the views left where the fit has their labels: a cover's (issue 46).
    arguments=lambda agent, _: {"net_arch": list(agent.net_arch),
                                "views_left": agent.pretrain_target != "values"},
    algorithms=("dqn",)))
