"""when a sensor was registered and made inactive (no-data grace period, "inactive since" on its page)

Revision ID: 0008
Revises: 0007
Create Date: 2026-12-07
"""
import sqlalchemy as sa
from alembic import op

revision = '0008'
down_revision = '0007'
branch_labels = None
depends_on = None


def upgrade():
    with op.batch_alter_table('sensors', schema=None) as batch_op:
        batch_op.add_column(sa.Column('created_ts', sa.BigInteger(), nullable=True))
        batch_op.add_column(sa.Column('deactivated_ts', sa.BigInteger(), nullable=True))


def downgrade():
    with op.batch_alter_table('sensors', schema=None) as batch_op:
        batch_op.drop_column('deactivated_ts')
        batch_op.drop_column('created_ts')
