"""``python -m h2h_racing.policies``: the one-lap time of each driver on each track."""

from h2h_racing.policies.lap_times import lap_time_table

lap_time_table()
