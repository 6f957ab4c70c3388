"""View planners behind one interface: random agents, H_rec, B_SCP, uniform views, NBV, an agent
and a greedy oracle.

`base` holds the interface and the registry `PLANNERS`, which declares the bundled planners
(one module each, which registers itself) and imports one on the first lookup of its name;
`runner` builds planners by name (`make_planner`), plays one episode of a planner (`run`) and
plans one part end to end (`plan_part`, the `vprobot plan` job).

The package imports none of its modules, so that importing one (`base`, `candidates`) does not
import every planner.
"""
