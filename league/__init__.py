"""Self-play leagues, tournaments, ratings and their store (training: ``h2h_racing.training``)."""
