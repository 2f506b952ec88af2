"""The envs over the core: the PettingZoo env (``parallel``, the only pettingzoo importer, and the
env card), the Gymnasium view (``single_agent``), actions, rewards, infos and results.
"""
