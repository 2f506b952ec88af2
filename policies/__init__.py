"""Scripted and trained drivers."""
