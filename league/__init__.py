"""Training adapter, leagues, ratings and tournaments."""
