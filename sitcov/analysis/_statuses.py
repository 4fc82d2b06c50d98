"""The run statuses that summaries tally, in the order of their status codes.

Shared by the summary and the breakdowns (a module of its own so neither imports the other
for it). ``pending`` runs are counted apart; other statuses are not tallied.
"""

STATUSES = ("pass", "fail", "error", "timeout")
