# Reference values of the supF, aveF and expF structural-change tests from R's
# strucchange (Fstats + sctest, with Hansen's 1997 p-values, pvalue.Fstats), for
# tests/reference/test_break_test_reference.py.
#
#   Rscript tests/reference/strucchange/tests.R > tests/reference/strucchange/tests.json
#
# Needs the Debian packages r-base-core and r-cran-strucchange. The JSON holds the
# data (the series of confint.R and one without a break), the F statistics, the
# tests and a grid of p-values.
suppressMessages(library(strucchange))

case <- function(name, y, X, from) {
  frame <- data.frame(y = y, X)
  formula <- if (ncol(X) == 0) y ~ 1 else as.formula(paste("y ~", paste(colnames(X), collapse = " + ")))
  fs <- suppressWarnings(Fstats(formula, data = frame, from = from))
  tests <- lapply(c("supF", "aveF", "expF"), function(type) sctest(fs, type = type))
  list(
    name = name, y = as.numeric(y), X = unname(as.matrix(X)), from = from,
    fstats = as.numeric(fs$Fstats), breakpoint = fs$breakpoint, lambda = fs$par,
    first = round(start(fs$Fstats)[1] * fs$nobs + start(fs$Fstats)[2] - 1),
    statistics = sapply(tests, function(t) unname(t$statistic)),
    pvalues = sapply(tests, function(t) t$p.value)
  )
}

data("Nile")
data("UKDriverDeaths")
seat <- log10(UKDriverDeaths)
seat <- cbind(seat, lag(seat, k = -1), lag(seat, k = -12))
colnames(seat) <- c("y", "ylag1", "ylag12")
seat <- window(seat, start = c(1970, 1), end = c(1984, 12))

set.seed(1)  # the series of confint.R
n <- 240
x <- rnorm(n)
two_breaks <- ifelse(seq_len(n) <= 80, 1 + 0.5 * x, ifelse(seq_len(n) <= 170, -0.5 + 1.5 * x, 0.8 - 0.3 * x)) +
  rnorm(n, sd = 0.6)
noise_sd <- ifelse(seq_len(n) <= 120, 0.3, 1.2)
hetero <- ifelse(seq_len(n) <= 120, 2 + x, 3 + 0.2 * x) + rnorm(n, sd = noise_sd)
set.seed(2)
m <- 150
z <- rnorm(m)
w <- rnorm(m)
no_break <- 1 + 0.5 * z - 0.3 * w + rnorm(m)

cases <- list(
  case("nile", as.numeric(Nile), matrix(nrow = length(Nile), ncol = 0), 0.15),
  case("seatbelt", as.numeric(seat[, "y"]), data.frame(ylag1 = as.numeric(seat[, "ylag1"]),
       ylag12 = as.numeric(seat[, "ylag12"])), 0.1),
  case("two_breaks", two_breaks, data.frame(x = x), 0.15),
  case("heteroskedastic", hetero, data.frame(x = x), 0.15),
  case("no_break", no_break, data.frame(z = z, w = w), 0.2)
)

# p-values over statistics, numbers of regressors and trimmings: lambda < 1 is
# the trimming itself, 1 the Chow point (tau = 0.5), large lambda small tau
grid <- expand.grid(statistic = c(0.3, 1, 2.5, 5, 8, 12, 20, 35),
                    k = c(1, 2, 3, 7, 15, 40),
                    lambda = c(0.005, 0.2, 0.495, 1, 1.0005, 4, 32.1, 1e5),
                    type = c("supF", "aveF", "expF"), stringsAsFactors = FALSE)
grid$pvalue <- mapply(function(s, k, l, t) strucchange:::pvalue.Fstats(s, type = t, k = k, lambda = l),
                      grid$statistic, grid$k, grid$lambda, grid$type)

to_json <- function(value) {
  if (is.data.frame(value)) value <- as.list(value)
  if (is.list(value) && !is.null(names(value))) {
    return(paste0("{", paste(sprintf("\"%s\": %s", names(value), sapply(value, to_json)), collapse = ", "), "}"))
  }
  if (is.list(value)) return(paste0("[", paste(sapply(value, to_json), collapse = ", "), "]"))
  if (is.character(value) && length(value) == 1) return(sprintf("\"%s\"", value))
  if (is.character(value)) return(paste0("[", paste(sprintf("\"%s\"", value), collapse = ", "), "]"))
  if (is.matrix(value)) {
    if (nrow(value) == 0 || ncol(value) == 0) return(sprintf("{\"rows\": %d, \"cols\": %d, \"values\": []}", nrow(value), ncol(value)))
    return(sprintf("{\"rows\": %d, \"cols\": %d, \"values\": [%s]}", nrow(value), ncol(value),
                   paste(sprintf("%.17g", t(value)), collapse = ", ")))
  }
  paste0("[", paste(ifelse(is.na(value), "null", sprintf("%.17g", value)), collapse = ", "), "]")
}
cat(to_json(list(strucchange = as.character(packageVersion("strucchange")),
                 R = paste(R.version$major, R.version$minor, sep = "."),
                 cases = cases, pvalues = grid)), "\n")
