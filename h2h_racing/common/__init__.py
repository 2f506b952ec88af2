"""Small helpers shared by every part, importing nothing of the project: the commands' progress
line, JSON files read safely, processes that die with their parent, optional-dependency hints.
"""
