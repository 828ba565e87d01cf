"""Model-side evaluation: open-loop agreement of a trained policy with the expert (`agreement`).

The closed-loop benchmark (`rvn-eval`, tables, reports) is task code: `rvn_data.benchmark`.
"""
