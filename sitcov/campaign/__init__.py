"""Campaigns: configuration, the run loop, executors, the store, exports and replay."""

from sitcov.campaign._config import EXECUTION_ONLY, CampaignConfig, load_config
from sitcov.campaign._executors import (
    Executor,
    ProcessExecutor,
    RayExecutor,
    SerialExecutor,
    make_executor,
)
from sitcov.campaign._experiments import FAULT_LABELS, fault_table, run_fault_experiment
from sitcov.campaign._open import open_store
from sitcov.campaign._records import RunRecord
from sitcov.campaign._runner import (
    CampaignProgress,
    CampaignResult,
    no_effect_elements,
    run_campaign,
)
from sitcov.campaign._store import (
    RUN_STATUSES,
    CampaignBusyError,
    CampaignInfo,
    PlannedRun,
    Store,
    StoreError,
)

__all__ = [
    "EXECUTION_ONLY",
    "FAULT_LABELS",
    "RUN_STATUSES",
    "CampaignBusyError",
    "CampaignConfig",
    "CampaignInfo",
    "CampaignProgress",
    "CampaignResult",
    "Executor",
    "PlannedRun",
    "ProcessExecutor",
    "RayExecutor",
    "RunRecord",
    "SerialExecutor",
    "Store",
    "StoreError",
    "fault_table",
    "load_config",
    "make_executor",
    "no_effect_elements",
    "open_store",
    "run_campaign",
    "run_fault_experiment",
]
