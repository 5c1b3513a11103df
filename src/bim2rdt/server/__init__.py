"""bim2rdt.server: the dashboard and its API (FastAPI), served by ``bim2rdt serve``.

```python
from bim2rdt.server import create_app, ServerConfig
app = create_app(twin, monitor, identity=identity, config=ServerConfig(tokens=[...]), audit_log=path)
```
"""

from bim2rdt.server.auth import new_token, token_digest
from bim2rdt.server.config import ROLES, ServerConfig, TokenEntry

__all__ = ["ROLES", "ServerConfig", "TokenEntry", "create_app", "new_token", "token_digest"]


def __getattr__(name: str):
    if name == "create_app":  # FastAPI is imported on first use: reading the settings stays light
        from bim2rdt.server.app import create_app

        return create_app
    raise AttributeError(name)
