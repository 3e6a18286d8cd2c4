"""An agent of a user's own, given a name, as docs/extending.md, "An agent", writes it."""

from baselines import GoalFilter
from hri_bench.run.agents import AgentSpec, register_agent

EAGER = register_agent(AgentSpec(
    "eager-goalfilter", lambda ctx: GoalFilter(ctx.graph, len(ctx.runs), r0=ctx.r0,
                                               eta=0.3),
    role="baseline", description="a goal filter that joins at 30 % confidence"))
