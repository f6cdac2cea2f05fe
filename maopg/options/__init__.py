"""Options: macro-actions with an inner controller and a termination condition.

:mod:`~maopg.options.base` defines the abstraction and the small protocols through which an
option acts on its task; :mod:`~maopg.options.moves` and :mod:`~maopg.options.navigation` hold
the options that tasks with mobile robots share. Options never import a task: each task
implements the protocol its options are written against.
"""
