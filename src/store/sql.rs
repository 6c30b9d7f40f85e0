//! The little SQL both back ends share: typed values, and one trait over a
//! SQLite and a PostgreSQL transaction, so the store's queries and
//! migrations are written once. Statements use `?` placeholders; the
//! PostgreSQL side numbers them (`$1`, `$2`, ...).

use postgres::types::{ToSql, Type};

use super::StoreError;

/// A column value. Nulls carry their type, which PostgreSQL checks.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum SqlValue {
    /// 64-bit integer (`INTEGER` / `BIGINT`).
    Int(Option<i64>),
    /// Double (`REAL` / `DOUBLE PRECISION`).
    Real(Option<f64>),
    /// Text.
    Text(Option<String>),
}

impl SqlValue {
    pub(crate) fn text(s: &str) -> SqlValue {
        SqlValue::Text(Some(s.to_string()))
    }

    pub(crate) fn opt_text(s: Option<&str>) -> SqlValue {
        SqlValue::Text(s.map(str::to_string))
    }

    pub(crate) fn int(&self) -> Result<Option<i64>, StoreError> {
        match self {
            SqlValue::Int(v) => Ok(*v),
            other => Err(StoreError::Corrupt(format!(
                "expected an integer column, found {other:?}"
            ))),
        }
    }

    pub(crate) fn real(&self) -> Result<Option<f64>, StoreError> {
        match self {
            SqlValue::Real(v) => Ok(*v),
            // SQLite keeps a REAL that is integral as written.
            SqlValue::Int(v) => Ok(v.map(|i| i as f64)),
            other => Err(StoreError::Corrupt(format!(
                "expected a number column, found {other:?}"
            ))),
        }
    }

    pub(crate) fn text_opt(&self) -> Result<Option<String>, StoreError> {
        match self {
            SqlValue::Text(v) => Ok(v.clone()),
            // A NULL read back from SQLite has no type.
            SqlValue::Int(None) | SqlValue::Real(None) => Ok(None),
            other => Err(StoreError::Corrupt(format!(
                "expected a text column, found {other:?}"
            ))),
        }
    }

    pub(crate) fn text_req(&self, column: &str) -> Result<String, StoreError> {
        self.text_opt()?
            .ok_or_else(|| StoreError::Corrupt(format!("column {column} is NULL")))
    }
}

/// One transaction of either back end.
pub(crate) trait Conn {
    /// Runs a statement; returns the rows changed.
    fn exec(&mut self, sql: &str, params: &[SqlValue]) -> Result<u64, StoreError>;
    /// Runs a query; returns its rows.
    fn query(&mut self, sql: &str, params: &[SqlValue]) -> Result<Vec<Vec<SqlValue>>, StoreError>;
    /// Runs several statements without parameters.
    fn batch(&mut self, sql: &str) -> Result<(), StoreError>;
    /// Which back end, for the statements that differ.
    fn backend(&self) -> Backend;
}

/// The two back ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Backend {
    Sqlite,
    Postgres,
}

impl rusqlite::ToSql for SqlValue {
    fn to_sql(&self) -> rusqlite::Result<rusqlite::types::ToSqlOutput<'_>> {
        use rusqlite::types::{ToSqlOutput, Value as V};
        Ok(ToSqlOutput::Owned(match self {
            SqlValue::Int(Some(i)) => V::Integer(*i),
            SqlValue::Real(Some(r)) => V::Real(*r),
            SqlValue::Text(Some(s)) => V::Text(s.clone()),
            SqlValue::Int(None) | SqlValue::Real(None) | SqlValue::Text(None) => V::Null,
        }))
    }
}

fn from_sqlite(v: rusqlite::types::ValueRef<'_>) -> Result<SqlValue, StoreError> {
    use rusqlite::types::ValueRef as V;
    Ok(match v {
        V::Null => SqlValue::Int(None),
        V::Integer(i) => SqlValue::Int(Some(i)),
        V::Real(r) => SqlValue::Real(Some(r)),
        V::Text(t) => SqlValue::Text(Some(
            std::str::from_utf8(t)
                .map_err(|e| StoreError::Corrupt(format!("text that is not UTF-8: {e}")))?
                .to_string(),
        )),
        V::Blob(_) => return Err(StoreError::Corrupt("a binary value".into())),
    })
}

impl Conn for rusqlite::Transaction<'_> {
    fn exec(&mut self, sql: &str, params: &[SqlValue]) -> Result<u64, StoreError> {
        Ok(self.execute(sql, rusqlite::params_from_iter(params))? as u64)
    }

    fn query(&mut self, sql: &str, params: &[SqlValue]) -> Result<Vec<Vec<SqlValue>>, StoreError> {
        let mut st = self.prepare(sql)?;
        let n = st.column_count();
        let mut rows = st.query(rusqlite::params_from_iter(params))?;
        let mut out = Vec::new();
        while let Some(r) = rows.next()? {
            out.push(
                (0..n)
                    .map(|i| from_sqlite(r.get_ref(i)?))
                    .collect::<Result<Vec<_>, StoreError>>()?,
            );
        }
        Ok(out)
    }

    fn batch(&mut self, sql: &str) -> Result<(), StoreError> {
        Ok(self.execute_batch(sql)?)
    }

    fn backend(&self) -> Backend {
        Backend::Sqlite
    }
}

/// `?` placeholders numbered for PostgreSQL.
fn numbered(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len() + 8);
    let mut k = 0;
    for ch in sql.chars() {
        if ch == '?' {
            k += 1;
            out.push('$');
            out.push_str(&k.to_string());
        } else {
            out.push(ch);
        }
    }
    out
}

fn pg_params(params: &[SqlValue]) -> Vec<&(dyn ToSql + Sync)> {
    params
        .iter()
        .map(|v| match v {
            SqlValue::Int(i) => i as &(dyn ToSql + Sync),
            SqlValue::Real(r) => r as &(dyn ToSql + Sync),
            SqlValue::Text(t) => t as &(dyn ToSql + Sync),
        })
        .collect()
}

fn from_pg(row: &postgres::Row, i: usize) -> Result<SqlValue, StoreError> {
    let t = row.columns()[i].type_();
    Ok(if *t == Type::INT8 {
        SqlValue::Int(row.try_get(i)?)
    } else if *t == Type::INT4 {
        SqlValue::Int(row.try_get::<_, Option<i32>>(i)?.map(i64::from))
    } else if *t == Type::FLOAT8 {
        SqlValue::Real(row.try_get(i)?)
    } else if *t == Type::TEXT || *t == Type::VARCHAR {
        SqlValue::Text(row.try_get(i)?)
    } else {
        return Err(StoreError::Corrupt(format!(
            "column {} has type {t}, which the store does not use",
            row.columns()[i].name()
        )));
    })
}

impl Conn for postgres::Transaction<'_> {
    fn exec(&mut self, sql: &str, params: &[SqlValue]) -> Result<u64, StoreError> {
        Ok(self.execute(numbered(sql).as_str(), &pg_params(params))?)
    }

    fn query(&mut self, sql: &str, params: &[SqlValue]) -> Result<Vec<Vec<SqlValue>>, StoreError> {
        let rows = postgres::Transaction::query(self, numbered(sql).as_str(), &pg_params(params))?;
        rows.iter()
            .map(|r| (0..r.len()).map(|i| from_pg(r, i)).collect())
            .collect()
    }

    fn batch(&mut self, sql: &str) -> Result<(), StoreError> {
        Ok(self.batch_execute(sql)?)
    }

    fn backend(&self) -> Backend {
        Backend::Postgres
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_are_numbered_in_order() {
        assert_eq!(
            numbered("INSERT INTO t (a, b) VALUES (?, ?) RETURNING id"),
            "INSERT INTO t (a, b) VALUES ($1, $2) RETURNING id"
        );
    }
}
