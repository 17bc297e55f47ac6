//! The small expression language of the findings files (`findings/seed*.toml`): arithmetic on
//! named numbers, comparisons, `and` / `or`, and the functions `max`, `min`, `abs` and
//! `degrees`. Each operation is the one `f64` operation of the same name, so a criterion written
//! here decides exactly as the same expression written in Rust.
//!
//! ```text
//! or      := and ("or" and)*
//! and     := compare ("and" compare)*
//! compare := sum (("<" | "<=" | ">" | ">=") sum)?
//! sum     := product (("+" | "-") product)*
//! product := unary (("*" | "/") unary)*
//! unary   := "-" unary | atom
//! atom    := number | "true" | "false" | name | name "(" or ("," or)* ")" | "(" or ")"
//! ```

use std::collections::BTreeSet;

use anyhow::{anyhow, bail, Result};

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Number(f64),
    Boolean(bool),
    Name(String),
    Negate(Box<Expr>),
    Binary(Box<Expr>, Operator, Box<Expr>),
    Call(Function, Vec<Expr>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Operator {
    Add,
    Subtract,
    Multiply,
    Divide,
    Less,
    LessOrEqual,
    Greater,
    GreaterOrEqual,
    And,
    Or,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Function {
    /// `f64::max`, folded from the left (a NaN argument is skipped, as `f64::max` does).
    Max,
    /// `f64::min`, folded from the left.
    Min,
    Abs,
    /// Radians to degrees (`f64::to_degrees`).
    Degrees,
}

/// What an expression evaluates to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    Number(f64),
    Boolean(bool),
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Number(f64),
    Name(String),
    Symbol(&'static str),
}

const SYMBOLS: [&str; 11] = ["<=", ">=", "<", ">", "+", "-", "*", "/", "(", ")", ","];

fn tokenize(text: &str) -> Result<Vec<Token>> {
    let mut tokens = Vec::new();
    let mut rest = text.trim_start();
    while !rest.is_empty() {
        if let Some(symbol) = SYMBOLS.into_iter().find(|s| rest.starts_with(s)) {
            tokens.push(Token::Symbol(symbol));
            rest = &rest[symbol.len()..];
        } else if rest.starts_with(|c: char| c.is_ascii_digit() || c == '.') {
            let end = number_end(rest);
            let number = rest[..end]
                .parse()
                .map_err(|_| anyhow!("{:?} is not a number", &rest[..end]))?;
            tokens.push(Token::Number(number));
            rest = &rest[end..];
        } else if rest.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
            let end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            tokens.push(Token::Name(rest[..end].to_string()));
            rest = &rest[end..];
        } else {
            bail!("unexpected {:?}", rest.chars().next().unwrap_or(' '));
        }
        rest = rest.trim_start();
    }
    Ok(tokens)
}

/// Length of the number literal at the start of `text` (digits, point, exponent with sign).
fn number_end(text: &str) -> usize {
    let bytes = text.as_bytes();
    let mut end = 0;
    while end < bytes.len() {
        let c = bytes[end];
        let exponent_sign =
            (c == b'-' || c == b'+') && end > 0 && matches!(bytes[end - 1], b'e' | b'E');
        if c.is_ascii_digit() || c == b'.' || c == b'e' || c == b'E' || exponent_sign {
            end += 1;
        } else {
            break;
        }
    }
    end
}

struct Parser {
    tokens: Vec<Token>,
    position: usize,
}

impl Parser {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.position)
    }

    fn next(&mut self) -> Option<Token> {
        let token = self.tokens.get(self.position).cloned();
        self.position += 1;
        token
    }

    fn eat_symbol(&mut self, symbol: &str) -> bool {
        let found = matches!(self.peek(), Some(Token::Symbol(s)) if *s == symbol);
        self.position += usize::from(found);
        found
    }

    fn eat_word(&mut self, word: &str) -> bool {
        let found = matches!(self.peek(), Some(Token::Name(n)) if n == word);
        self.position += usize::from(found);
        found
    }

    fn or(&mut self) -> Result<Expr> {
        let mut left = self.and()?;
        while self.eat_word("or") {
            left = Expr::Binary(Box::new(left), Operator::Or, Box::new(self.and()?));
        }
        Ok(left)
    }

    fn and(&mut self) -> Result<Expr> {
        let mut left = self.compare()?;
        while self.eat_word("and") {
            left = Expr::Binary(Box::new(left), Operator::And, Box::new(self.compare()?));
        }
        Ok(left)
    }

    fn compare(&mut self) -> Result<Expr> {
        let left = self.sum()?;
        for (symbol, operator) in [
            ("<=", Operator::LessOrEqual),
            (">=", Operator::GreaterOrEqual),
            ("<", Operator::Less),
            (">", Operator::Greater),
        ] {
            if self.eat_symbol(symbol) {
                return Ok(Expr::Binary(
                    Box::new(left),
                    operator,
                    Box::new(self.sum()?),
                ));
            }
        }
        Ok(left)
    }

    fn sum(&mut self) -> Result<Expr> {
        let mut left = self.product()?;
        loop {
            let operator = if self.eat_symbol("+") {
                Operator::Add
            } else if self.eat_symbol("-") {
                Operator::Subtract
            } else {
                return Ok(left);
            };
            left = Expr::Binary(Box::new(left), operator, Box::new(self.product()?));
        }
    }

    fn product(&mut self) -> Result<Expr> {
        let mut left = self.unary()?;
        loop {
            let operator = if self.eat_symbol("*") {
                Operator::Multiply
            } else if self.eat_symbol("/") {
                Operator::Divide
            } else {
                return Ok(left);
            };
            left = Expr::Binary(Box::new(left), operator, Box::new(self.unary()?));
        }
    }

    fn unary(&mut self) -> Result<Expr> {
        if self.eat_symbol("-") {
            return Ok(Expr::Negate(Box::new(self.unary()?)));
        }
        self.atom()
    }

    fn atom(&mut self) -> Result<Expr> {
        match self.next() {
            Some(Token::Number(x)) => Ok(Expr::Number(x)),
            Some(Token::Symbol("(")) => {
                let inner = self.or()?;
                self.expect(")")?;
                Ok(inner)
            }
            Some(Token::Name(name)) if name == "true" || name == "false" => {
                Ok(Expr::Boolean(name == "true"))
            }
            Some(Token::Name(name)) if self.eat_symbol("(") => self.call(&name),
            Some(Token::Name(name)) => Ok(Expr::Name(name)),
            other => bail!("expected a number, a name or '(', found {other:?}"),
        }
    }

    fn call(&mut self, name: &str) -> Result<Expr> {
        let function = match name {
            "max" => Function::Max,
            "min" => Function::Min,
            "abs" => Function::Abs,
            "degrees" => Function::Degrees,
            _ => bail!("unknown function {name:?} (max, min, abs, degrees)"),
        };
        let mut arguments = vec![self.or()?];
        while self.eat_symbol(",") {
            arguments.push(self.or()?);
        }
        self.expect(")")?;
        let unary = matches!(function, Function::Abs | Function::Degrees);
        if unary != (arguments.len() == 1) {
            bail!(
                "{name} takes {}",
                if unary {
                    "one argument"
                } else {
                    "two or more arguments"
                }
            );
        }
        Ok(Expr::Call(function, arguments))
    }

    fn expect(&mut self, symbol: &str) -> Result<()> {
        if self.eat_symbol(symbol) {
            Ok(())
        } else {
            bail!("expected {symbol:?}, found {:?}", self.peek())
        }
    }
}

impl Expr {
    /// Parses `text`; the error names the text.
    pub fn parse(text: &str) -> Result<Expr> {
        let context = || format!("expression {text:?}");
        let tokens = tokenize(text).map_err(|e| e.context(context()))?;
        let mut parser = Parser {
            tokens,
            position: 0,
        };
        let expr = parser.or().map_err(|e| e.context(context()))?;
        if let Some(token) = parser.peek() {
            bail!("{}: unexpected {token:?} after the end", context());
        }
        Ok(expr)
    }

    /// Every name the expression reads.
    pub fn names(&self, into: &mut BTreeSet<String>) {
        match self {
            Expr::Number(_) | Expr::Boolean(_) => {}
            Expr::Name(name) => {
                into.insert(name.clone());
            }
            Expr::Negate(inner) => inner.names(into),
            Expr::Binary(left, _, right) => {
                left.names(into);
                right.names(into);
            }
            Expr::Call(_, arguments) => arguments.iter().for_each(|a| a.names(into)),
        }
    }

    /// Evaluates with `lookup` giving the value of each name.
    pub fn evaluate(&self, lookup: &mut dyn FnMut(&str) -> Result<f64>) -> Result<Value> {
        Ok(match self {
            Expr::Number(x) => Value::Number(*x),
            Expr::Boolean(b) => Value::Boolean(*b),
            Expr::Name(name) => Value::Number(lookup(name)?),
            Expr::Negate(inner) => Value::Number(-inner.number(lookup)?),
            Expr::Binary(left, operator, right) => binary(left, *operator, right, lookup)?,
            Expr::Call(function, arguments) => {
                let mut values = Vec::with_capacity(arguments.len());
                for argument in arguments {
                    values.push(argument.number(lookup)?);
                }
                Value::Number(match function {
                    Function::Max => values[1..].iter().fold(values[0], |m, &x| m.max(x)),
                    Function::Min => values[1..].iter().fold(values[0], |m, &x| m.min(x)),
                    Function::Abs => values[0].abs(),
                    Function::Degrees => values[0].to_degrees(),
                })
            }
        })
    }

    /// Evaluates to a number, or says it is a truth value.
    pub fn number(&self, lookup: &mut dyn FnMut(&str) -> Result<f64>) -> Result<f64> {
        match self.evaluate(lookup)? {
            Value::Number(x) => Ok(x),
            Value::Boolean(_) => bail!("{self:?} is a truth value where a number is needed"),
        }
    }

    /// Evaluates to a truth value, or says it is a number.
    pub fn truth(&self, lookup: &mut dyn FnMut(&str) -> Result<f64>) -> Result<bool> {
        match self.evaluate(lookup)? {
            Value::Boolean(b) => Ok(b),
            Value::Number(_) => bail!("{self:?} is a number where a truth value is needed"),
        }
    }
}

fn binary(
    left: &Expr,
    operator: Operator,
    right: &Expr,
    lookup: &mut dyn FnMut(&str) -> Result<f64>,
) -> Result<Value> {
    if let Operator::And | Operator::Or = operator {
        let (a, b) = (left.truth(lookup)?, right.truth(lookup)?);
        return Ok(Value::Boolean(match operator {
            Operator::And => a && b,
            _ => a || b,
        }));
    }
    let (a, b) = (left.number(lookup)?, right.number(lookup)?);
    Ok(match operator {
        Operator::Add => Value::Number(a + b),
        Operator::Subtract => Value::Number(a - b),
        Operator::Multiply => Value::Number(a * b),
        Operator::Divide => Value::Number(a / b),
        Operator::Less => Value::Boolean(a < b),
        Operator::LessOrEqual => Value::Boolean(a <= b),
        Operator::Greater => Value::Boolean(a > b),
        Operator::GreaterOrEqual => Value::Boolean(a >= b),
        Operator::And | Operator::Or => unreachable!("handled above"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(text: &str, names: &[(&str, f64)]) -> Value {
        let mut lookup = |name: &str| {
            names
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, v)| *v)
                .ok_or_else(|| anyhow!("no {name}"))
        };
        Expr::parse(text).unwrap().evaluate(&mut lookup).unwrap()
    }

    #[test]
    fn arithmetic_follows_precedence_and_f64_operations() {
        let (a, b, c) = (0.1, 0.2, 3.7);
        assert_eq!(
            eval("a + b * c - 1e-2 / a", &[("a", a), ("b", b), ("c", c)]),
            Value::Number(a + b * c - 1e-2 / a)
        );
        assert_eq!(
            eval("-(a - b)", &[("a", a), ("b", b)]),
            Value::Number(-(a - b))
        );
        assert_eq!(
            eval(
                "max(a, b, c) + abs(a - c) + degrees(b)",
                &[("a", a), ("b", b), ("c", c)]
            ),
            Value::Number(a.max(b).max(c) + (a - c).abs() + b.to_degrees())
        );
        assert_eq!(eval("max(x, 1.0)", &[("x", f64::NAN)]), Value::Number(1.0));
    }

    #[test]
    fn comparisons_and_logic() {
        let names = [("x", 2.0), ("y", 3.0)];
        assert_eq!(eval("x < y and y <= 3", &names), Value::Boolean(true));
        assert_eq!(eval("x > y or x >= 2.5", &names), Value::Boolean(false));
        assert_eq!(eval("x > 5 * y or true", &names), Value::Boolean(true));
        assert_eq!(eval("x < y and x > y", &names), Value::Boolean(false));
    }

    #[test]
    fn errors_name_the_problem() {
        for (text, expected) in [
            ("x <", "expected a number"),
            ("max(x)", "two or more"),
            ("sqrt(x)", "unknown function"),
            ("x y", "after the end"),
            ("x # y", "unexpected '#'"),
            ("(x", "expected \")\""),
        ] {
            let error = format!("{:#}", Expr::parse(text).unwrap_err());
            assert!(error.contains(expected), "{text}: {error}");
        }
        let mut lookup = |_: &str| Ok(1.0);
        let error = Expr::parse("x + 1")
            .unwrap()
            .truth(&mut lookup)
            .unwrap_err();
        assert!(error.to_string().contains("truth value is needed"));
    }
}
