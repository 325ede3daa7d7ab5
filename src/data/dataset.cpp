// placeholder: replaced by the dataset reader/writer
